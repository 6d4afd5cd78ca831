// Running external programs (gnuplot, ffmpeg, node) through the shell.
#pragma once

#include <string>

namespace haha {

// A shell word: `s` in single quotes (embedded quotes escaped).
std::string shell_quoted(const std::string& s);

// Runs a shell command; returns its exit status (-1: could not start) and its combined
// stdout + stderr in `output`.
int run_capture(const std::string& cmd, std::string& output);

// Runs a shell command with the caller's stdout and stderr; returns its exit status (0 =
// success; -1: could not start or killed by a signal). Throws haha::Error("interrupted")
// once the child has ended when the interrupt flag is set (core/interrupt.h); the child gets
// a SIGTERM as soon as the flag is seen.
int run_command(const std::string& cmd);

// Whether `program` is found on PATH (`command -v`).
bool program_on_path(const std::string& program);

// The last non-blank line of `s` ("no output" when there is none).
std::string last_line(const std::string& s);

}  // namespace haha
