// The `haha` command line. Subcommands register themselves (command.h).
#include <algorithm>
#include <cstdio>
#include <exception>
#include <utility>
#include <vector>

#include "command.h"
#include "core/error.h"
#include "core/parallel.h"

namespace haha::cli {

static std::vector<std::pair<std::string, CommandSetup>>& registry() {
  static std::vector<std::pair<std::string, CommandSetup>> r;
  return r;
}

bool register_command(const char* name, CommandSetup setup) {
  registry().emplace_back(name, setup);
  return true;
}

}  // namespace haha::cli

int main(int argc, char** argv) {
  CLI::App app{"haha: train, pack and render HAHA avatars (Gaussians bound to a textured SMPL-X mesh)"};
  app.require_subcommand(1);
  int threads = 0;
  app.add_option("--threads", threads, "CPU threads (default: all cores)");
  auto& reg = haha::cli::registry();
  std::sort(reg.begin(), reg.end());
  for (auto& [name, setup] : reg) setup(app);
  app.parse_complete_callback([&] { haha::set_num_threads(threads); });
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "haha: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
