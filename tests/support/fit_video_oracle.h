// An ORACLE fitter for the plumbing tests of `haha fit-video` (app/fit_video_run.h): it
// returns a synthetic dataset's true camera and parameters for each frame it is given,
// drops the frames it is told to, and reports made-up, frame-dependent errors so the tests
// can follow each value into the report. It fits nothing: plumbing tests only.
#pragma once

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

#include "fit/fit_video.h"
#include "data/dataset.h"

namespace haha::test {

struct OracleFitter {
  const Dataset* truth = nullptr;  // the synthetic dataset the input frames came from
  std::vector<int> source;         // per input frame: its frame in `truth`
  std::set<int> drop;              // input frames to report as dropped
  mutable int calls = 0;
  mutable FitVideoOptions seen{};  // the options of the last call

  static double reprojection(int i) { return 1.0 + 0.25 * i; }
  static double iou(int i) { return 0.9 - 0.01 * i; }

  FitVideoResult operator()(const std::vector<FitVideoInputFrame>& frames, const FitVideoOptions& opt) const {
    ++calls;
    seen = opt;
    FitVideoResult r;
    EXPECT_EQ(frames.size(), source.size());
    r.camera = truth->frames.at(0).camera;
    for (size_t i = 0; i < frames.size() && i < source.size(); ++i) {
      EXPECT_EQ(frames[i].keypoints.width, truth->width);
      EXPECT_EQ(frames[i].keypoints.height, truth->height);
      EXPECT_EQ(frames[i].mask.width, truth->width);
      FitVideoFrameReport rep;
      rep.frame = frames[i].keypoints.frame;
      if (drop.count(int(i))) {
        rep.dropped = true;
        rep.reason = "oracle says drop";
      } else {
        rep.reprojection_px = reprojection(int(i));
        rep.silhouette_iou = iou(int(i));
        r.kept.push_back(int(i));
        r.params.push_back(truth->frames.at(size_t(source[i])).params);
      }
      r.report.push_back(rep);
    }
    return r;
  }
};

}  // namespace haha::test
