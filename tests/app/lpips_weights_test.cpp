// The LPIPS weight-file reader: a round trip of weights the test writes (the layout of
// train/lpips.h), and one-line errors naming the file (and key) for bad files. Shape and
// key checks against the architecture are LpipsNet's (train_lpips_test.cpp).
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <unistd.h>

#include "app/lpips_weights.h"
#include "core/error.h"
#include "io/npy.h"
#include "support/expect_error.h"

using namespace haha;

namespace {
std::string tmp(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("haha_lpipsw_" + std::to_string(::getpid()) + "_" + name)).string();
}
using haha::test::expect_error;
}  // namespace

TEST(LpipsWeightsFile, RoundTripKeepsLpipsArraysAndSkipsOthers) {
  Npz z;
  z.set("alex.features.0.weight", NpyArray::from(std::vector<float>{1, 2, 3, 4, 5, 6}, {2, 3, 1, 1}));
  z.set("alex.features.0.bias", NpyArray::from(std::vector<double>{0.5, -0.25}, {2}));  // f64 converts
  z.set("vgg.lin.0.weight", NpyArray::from(std::vector<float>{7, 8}, {1, 2, 1, 1}));
  z.set("notes", NpyArray::from(std::vector<int32_t>{1}, {1}));  // not an LPIPS key: ignored
  const std::string p = tmp("ok.npz");
  z.write(p);
  const LpipsWeights w = read_lpips_weights(p);
  EXPECT_EQ(w.source, p);
  EXPECT_EQ(w.tensors.size(), 3u);
  EXPECT_EQ(w.tensors.at("alex.features.0.weight").shape, (std::vector<int64_t>{2, 3, 1, 1}));
  EXPECT_EQ(w.tensors.at("alex.features.0.weight").data, (std::vector<float>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(w.tensors.at("alex.features.0.bias").data, (std::vector<float>{0.5f, -0.25f}));
  EXPECT_TRUE(w.has_backbone(LpipsBackbone::Alex));
  EXPECT_TRUE(w.has_backbone(LpipsBackbone::Vgg16));
  EXPECT_EQ(w.tensors.count("notes"), 0u);
  std::remove(p.c_str());
}

TEST(LpipsWeightsFile, BadFilesGiveOneLineErrors) {
  expect_error([] { read_lpips_weights("/nonexistent/lpips.npz"); }, "/nonexistent/lpips.npz");
  const std::string junk = tmp("junk.npz");
  { std::ofstream(junk) << "not a zip archive"; }
  expect_error([&] { read_lpips_weights(junk); }, junk);
  std::remove(junk.c_str());

  Npz ints;
  ints.set("alex.features.0.weight", NpyArray::from(std::vector<int32_t>{1, 2}, {2}));
  const std::string pi = tmp("ints.npz");
  ints.write(pi);
  expect_error([&] { read_lpips_weights(pi); }, pi, "alex.features.0.weight: expected float32");
  std::remove(pi.c_str());

  Npz none;
  none.set("weights", NpyArray::from(std::vector<float>{1}, {1}));
  const std::string pn = tmp("none.npz");
  none.write(pn);
  expect_error([&] { read_lpips_weights(pn); }, pn, "no LPIPS arrays");
  std::remove(pn.c_str());

  // A NaN or Inf weight would turn every LPIPS loss and metric into NaN: refused up front.
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    Npz nan;
    nan.set("alex.features.0.weight", NpyArray::from(std::vector<float>{1, 2, bad, 4}, {2, 2, 1, 1}));
    const std::string pf = tmp("nan.npz");
    nan.write(pf);
    expect_error([&] { read_lpips_weights(pf); }, pf, "alex.features.0.weight: non-finite value at flat index 2");
    std::remove(pf.c_str());
  }
}
