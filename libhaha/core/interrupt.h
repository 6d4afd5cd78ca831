// Ctrl-C for long commands: SIGINT / SIGTERM only set a flag; the long loops (decoding,
// waiting for a child program, optimiser iterations, writing frames) call
// check_interrupted(), which throws haha::Error("interrupted"). The error unwinds like any
// other, so staging directories and temporary files are removed and the command prints the
// one line `haha: error: interrupted` and exits non-zero. Children started in the same
// process group (ffmpeg, node) get the terminal's Ctrl-C themselves.
#pragma once

namespace haha {

// Installs the handler for SIGINT and SIGTERM (idempotent; commands that run long call it).
void install_interrupt_handler();

// What the handler does (also for tests), and its undoing.
void request_interrupt();
void clear_interrupt();
bool interrupted();

// Throws haha::Error("interrupted") when the flag is set.
void check_interrupted();

}  // namespace haha
