// Each `haha` subcommand lives in its own cli/cmd_*.cpp and registers itself:
//
//   HAHA_COMMAND(pack) {
//     auto* sub = app.add_subcommand("pack", "Pack a trained run into a .glb");
//     ... options ...
//     sub->callback([=] { ... });   // throw haha::Error for bad input
//   }
//
// main.cpp turns haha::Error (and any std::exception) into one line
// "haha: error: <message>" and exit code 1.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>

namespace haha::cli {

using CommandSetup = void (*)(CLI::App& app);
bool register_command(const char* name, CommandSetup setup);

// The value of `--threads`, wherever on the command line it stood; 0 when not given.
int requested_threads();

}  // namespace haha::cli

#define HAHA_COMMAND(name)                                                                        \
  static void haha_command_##name(CLI::App& app);                                                 \
  [[maybe_unused]] static const bool haha_command_##name##_registered =                          \
      haha::cli::register_command(#name, haha_command_##name);                                    \
  static void haha_command_##name(CLI::App& app)
