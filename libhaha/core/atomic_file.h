// Writes go to "<path>.tmp-<pid>-<n>" and are renamed over <path> only once complete, so a
// failed or interrupted command never leaves a half-written output file.
#pragma once

#include <functional>
#include <string>

namespace haha {

// Calls write(tmp_path); on success renames tmp_path to path, on exception removes it
// and rethrows.
void write_atomically(const std::string& path, const std::function<void(const std::string& tmp_path)>& write);

// A whole text file written atomically / read; haha::Error naming the file on failure.
void write_text_file(const std::string& path, const std::string& text);
std::string read_text_file(const std::string& path);

// Creates the directory (and parents); throws haha::Error naming it on failure.
void ensure_directory(const std::string& dir);

}  // namespace haha
