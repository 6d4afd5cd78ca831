// RUN/texture_evidence.npy is validated on read: a wrong shape or a bad value is one error
// line naming the file; an absent file is no evidence.
#include <gtest/gtest.h>

#include <filesystem>
#include <limits>
#include <vector>

#include "app/run_dir.h"
#include "io/npy.h"
#include "support/expect_error.h"

using namespace haha;
namespace fs = std::filesystem;

TEST(TextureEvidenceFile, ReadsItsShapeAndRejectsWhatIsNotEvidence) {
  const fs::path dir = fs::temp_directory_path() / ("haha-evidence-" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()));
  fs::create_directories(dir);
  const RunDir run(dir.string());
  EXPECT_TRUE(read_texture_evidence(run, 4).empty());  // absent: none
  std::vector<float> e(16, 0.5f);
  write_npy(run.texture_evidence(), NpyArray::from(e, {4, 4}));
  EXPECT_EQ(read_texture_evidence(run, 4), e);
  test::expect_error([&] { read_texture_evidence(run, 8); }, {run.texture_evidence(), "(8, 8)"});
  write_npy(run.texture_evidence(), NpyArray::from(e, {16}));
  test::expect_error([&] { read_texture_evidence(run, 4); }, {run.texture_evidence()});
  e[3] = -1;
  write_npy(run.texture_evidence(), NpyArray::from(e, {4, 4}));
  test::expect_error([&] { read_texture_evidence(run, 4); }, {run.texture_evidence(), "negative"});
  e[3] = std::numeric_limits<float>::quiet_NaN();
  write_npy(run.texture_evidence(), NpyArray::from(e, {4, 4}));
  test::expect_error([&] { read_texture_evidence(run, 4); }, {run.texture_evidence(), "non-finite"});
  fs::remove_all(dir);
}
