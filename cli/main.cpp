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

static int requested_threads_ = 0;

int requested_threads() { return requested_threads_; }

// `--threads N` may stand before the subcommand (`haha --threads 2 train`) or after it
// (`haha train --threads 2`, as a newcomer types it): every subcommand, nested ones too, has
// the option, so that its --help lists it. All of them write the same value.
static void add_threads_option(CLI::App& app) {
  app.add_option("--threads", requested_threads_, "CPU threads (default: all cores)");
  for (CLI::App* sub : app.get_subcommands([](CLI::App* s) { return !s->get_name().empty(); })) add_threads_option(*sub);
}

}  // namespace haha::cli

int main(int argc, char** argv) {
  CLI::App app{"haha: train, pack and render HAHA avatars (Gaussians bound to a textured SMPL-X mesh)"};
  app.require_subcommand(1);
  auto& reg = haha::cli::registry();
  std::sort(reg.begin(), reg.end());
  for (auto& [name, setup] : reg) setup(app);
  haha::cli::add_threads_option(app);
  app.parse_complete_callback([] { haha::set_num_threads(haha::cli::requested_threads()); });
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
