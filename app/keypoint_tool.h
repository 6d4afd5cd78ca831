// Running tools/keypoints (docs/keypoints.md) from C++: finding it, checking that Node and
// its node_modules are installed, and running it over a folder of frames.
#pragma once

#include <string>

namespace haha {

// The tool's folder (holding keypoints.mjs): $HAHA_KEYPOINTS_TOOL when set, else
// `configured` when not empty, else the first tools/keypoints found walking up from the
// running executable's folder (a build tree inside the source tree), else the source tree
// this was built from. The result may not exist: check_keypoint_tool says so.
std::string find_keypoint_tool(const std::string& configured = "");

// One haha::Error line saying what is missing and how to install it: node (apt-get install
// nodejs npm), the tool's keypoints.mjs, or its node_modules (scripts/setup-keypoints.sh).
void check_keypoint_tool(const std::string& tool_dir);

// node TOOL/keypoints.mjs IN_DIR OUT_DIR --mask MASK (`fast`: also --flip off --movenet off,
// BlazePose once per frame; docs/keypoints.md): its progress lines go to stdout when
// `progress`, its stderr to `log_path`; a failure throws haha::Error with the tool's error
// line.
void run_keypoint_tool(const std::string& tool_dir, const std::string& in_dir, const std::string& out_dir,
                       const std::string& mask_mode, bool fast, bool progress, const std::string& log_path);

}  // namespace haha
