#include "app/subprocess.h"

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace haha {

std::string shell_quoted(const std::string& s) {
  std::string o = "'";
  for (char c : s) o += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return o + "'";
}

int run_capture(const std::string& cmd, std::string& output) {
  output.clear();
  std::fflush(stdout);
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return -1;
  std::array<char, 512> buf{};
  while (std::fgets(buf.data(), int(buf.size()), p)) output += buf.data();
  return pclose(p);
}

int run_command(const std::string& cmd) {
  std::fflush(stdout);  // our progress lines stay before the child's
  std::fflush(stderr);
  const int st = std::system(cmd.c_str());
  if (st == -1 || !WIFEXITED(st)) return -1;
  return WEXITSTATUS(st);
}

bool program_on_path(const std::string& program) {
  std::string out;
  return run_capture("command -v " + shell_quoted(program), out) == 0 && !out.empty();
}

std::string last_line(const std::string& s) {
  std::istringstream in(s);
  std::string line, last;
  while (std::getline(in, line))
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  return last.empty() ? "no output" : last;
}

}  // namespace haha
