#include "core/subprocess.h"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "core/interrupt.h"

extern char** environ;

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
  // sh -c, as std::system, but waited for here: std::system ignores SIGINT while it waits,
  // and the interrupt flag (core/interrupt.h) must be seen.
  pid_t pid = 0;
  const char* argv[] = {"sh", "-c", cmd.c_str(), nullptr};
  if (posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char* const*>(argv), environ) != 0) return -1;
  int st = 0;
  bool passed_on = false;
  for (;;) {
    const pid_t r = waitpid(pid, &st, WNOHANG);
    if (r == pid) break;
    if (r < 0 && errno != EINTR) return -1;
    if (interrupted() && !passed_on) {  // e.g. a SIGTERM sent to haha alone: the child stops too
      kill(pid, SIGTERM);
      passed_on = true;
    }
    usleep(20000);
  }
  check_interrupted();
  if (!WIFEXITED(st)) return -1;
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
