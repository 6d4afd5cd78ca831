#include "app/keypoint_tool.h"

#include <cstdlib>
#include <filesystem>

#include "core/subprocess.h"
#include "core/atomic_file.h"
#include "core/error.h"

namespace haha {

namespace fs = std::filesystem;

std::string find_keypoint_tool(const std::string& configured) {
  if (const char* env = std::getenv("HAHA_KEYPOINTS_TOOL"); env && *env) return env;
  if (!configured.empty()) return configured;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec)
    for (fs::path d = exe.parent_path(); !d.empty(); d = d.parent_path()) {
      for (const fs::path& cand : {d / "tools" / "keypoints", d / "share" / "haha" / "keypoints"})
        if (fs::is_regular_file(cand / "keypoints.mjs", ec)) return cand.string();
      if (d == d.root_path()) break;
    }
#ifdef HAHA_SOURCE_DIR
  return (fs::path(HAHA_SOURCE_DIR) / "tools" / "keypoints").string();
#else
  return "tools/keypoints";
#endif
}

void check_keypoint_tool(const std::string& tool_dir) {
  if (!program_on_path("node"))
    fail("node", "not installed; the keypoint tool needs Node 18 or later (apt-get install nodejs npm, then "
                 "scripts/setup-keypoints.sh)");
  std::error_code ec;
  const fs::path dir(tool_dir);
  if (!fs::is_regular_file(dir / "keypoints.mjs", ec))
    fail((dir / "keypoints.mjs").string(), "missing: the keypoint tool is not there (set HAHA_KEYPOINTS_TOOL to its "
                                           "folder, tools/keypoints in the source tree)");
  // The models are the last and largest package setup-keypoints.sh installs.
  if (!fs::is_directory(dir / "node_modules" / "@vladmandic" / "human-models" / "models", ec) ||
      !fs::is_directory(dir / "node_modules" / "@tensorflow" / "tfjs-backend-wasm", ec))
    fail((dir / "node_modules").string(), "the keypoint tool's packages are not installed (run scripts/setup-keypoints.sh)");
}

void run_keypoint_tool(const std::string& tool_dir, const std::string& in_dir, const std::string& out_dir,
                       const std::string& mask_mode, bool fast, bool progress, const std::string& log_path) {
  check_keypoint_tool(tool_dir);
  // exec: the shell becomes node, so a SIGTERM passed on by run_command reaches it.
  const std::string cmd = "exec node " + shell_quoted((fs::path(tool_dir) / "keypoints.mjs").string()) + " " +
                          shell_quoted(in_dir) + " " + shell_quoted(out_dir) + " --mask " + shell_quoted(mask_mode) +
                          (fast ? " --flip off --movenet off" : "") + (progress ? "" : " > /dev/null") + " 2> " +
                          shell_quoted(log_path);
  if (run_command(cmd) != 0) {
    std::string log;
    try {
      log = read_text_file(log_path);
    } catch (const Error&) {
    }
    // The tool's own one-line error ("keypoints: error: <file>: <problem>") names the file.
    const std::string line = last_line(log), prefix = "keypoints: error: ";
    if (line.rfind(prefix, 0) == 0) throw Error(line.substr(prefix.size()));
    fail("keypoint tool", line + " (log: " + log_path + ")");
  }
}

}  // namespace haha
