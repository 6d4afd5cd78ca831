// `haha convert`'s driver: real data (X-Humans, PeopleSnapshot/InstantAvatar, SMPLify-X
// fits) into the native dataset format (data/dataset.h) that `haha train` reads. Every input
// file of the selected frames is validated before anything is written; the output directory
// appears only when complete. PeopleSnapshot's SMPL poses become SMPL-X by fitting
// (fit/smpl_fit.h), never by copying numbers.
#pragma once

#include <string>
#include <vector>

namespace haha {

// The command's options, named as its flags.
struct ConvertRunOptions {
  std::string from, out, body, hand_mean = "flat", gender, train_frames, test_frames, smpl_model, smpl_correspondence;
  int fit_iterations = 500;
  std::vector<std::string> in, test;
  int size = 0, every = 1, max_frames = 0;
  double fps = 30, focal = 5000, depth_threshold = 700;
  bool no_crop = false;
};

// Converts and writes the dataset, printing the SMPL-X fit's residuals and one summary
// line. Throws haha::Error naming the option or file for bad input.
void run_convert(const ConvertRunOptions& options);

}  // namespace haha
