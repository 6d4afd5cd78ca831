// The frames of `haha fit-video`: a video file decoded with the ffmpeg program, or a folder
// of images read in name order; a --frames A:B:S selection applied after decoding; the
// selected frames written as WORK/frames/%06d.png (the keypoint tool's input).
#pragma once

#include <string>
#include <vector>

namespace haha {

// --frames A:B:S: first frame A, last B exclusive (-1: to the end), step S (>= 1).
struct FrameRange {
  int first = 0, last = -1, step = 1;
};

// "A:B:S", "A:B", "A:", ":B", "A" (from A on), "" (all); each part a non-negative integer,
// B > A when given, S >= 1. Throws haha::Error "--frames: ...".
FrameRange parse_frame_range(const std::string& text);

// Indices of [0, n) the range selects, in order.
std::vector<int> select_frames(const FrameRange& r, int n);

struct InputFrames {
  bool is_video = false;
  double fps = 0;                   // of the frames (before the step): --fps, the video's rate, or 30 for a folder
  int decoded = 0;                  // frames decoded (video) or images found (folder)
  int width = 0, height = 0;
  std::vector<int> source_index;    // per selected frame: its index among the decoded frames
  std::vector<std::string> names;   // per selected frame: image file name (folder) or "frame N" (video)
  std::vector<std::string> paths;   // per selected frame: WORK/frames/%06d.png
};

// Cheap checks before any long work: the input exists; a video: ffmpeg and ffprobe are
// installed and ffprobe reads a video stream; a folder: it holds png/jpg images, all of one
// size. Throws haha::Error "<input>: <problem>".
void check_input(const std::string& input);

// Decodes or copies the selected frames into work_dir/frames (created). fps > 0: a video is
// resampled to that rate (ffmpeg -vf fps=F); a folder's images are taken to be at that rate.
// Throws haha::Error for an undecodable video, zero frames, a selection that keeps nothing,
// or images of different sizes.
InputFrames prepare_input_frames(const std::string& input, const std::string& work_dir, double fps,
                                 const FrameRange& range, bool progress);

}  // namespace haha
