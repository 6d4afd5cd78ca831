// `haha convert --from peoplesnapshot` end to end: an InstantAvatar-layout folder whose poses
// are SMPL fits of an SMPL-layout stand-in (tests/support/peoplesnapshot_standin.h on
// body/smpl_standin.h: known template shift and shape). Without --smpl-model: exit 1, one
// line naming the missing SMPL model. With the stand-in and the SMPL-X model: per-frame
// residuals under 5 mm and the known offsets recovered in the converted dataset.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "data/dataset.h"
#include "support/haha_cli.h"
#include "support/peoplesnapshot_standin.h"

namespace haha {
namespace {

namespace fs = std::filesystem;
using haha::test::kHaha;
using haha::test::slurp;

TEST(ConvertPeopleSnapshotCli, FitsSmplxToSmplAndRefusesWithoutTheSmplModel) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-convert-ps-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const test::PeopleSnapshotStandin st = test::make_peoplesnapshot_standin(dir);  // frames 0, 2 train, 4 test
  const fs::path& ps = st.subject;
  const SmplStandinOptions& so = st.standin;
  const auto& transl = st.transl;

  const std::string base = "'" + kHaha.string() + "' convert --from peoplesnapshot --in '" + ps.string() +
                           "' --train-frames 0:4:2 --test-frames 4:6:2 --out '" + (dir / "out").string() + "'";
  const std::string redirect = " > '" + (dir / "o.txt").string() + "' 2> '" + (dir / "e.txt").string() + "'";
  // No SMPL model: exit 1, one line, naming it; nothing written.
  EXPECT_EQ(WEXITSTATUS(std::system((base + " --model '" + st.smplx.string() + "'" + redirect).c_str())), 1);
  const std::string e = slurp(dir / "e.txt");
  EXPECT_EQ(e.rfind("haha: error: --smpl-model: ", 0), 0u) << e;
  EXPECT_NE(e.find("SMPL model"), std::string::npos) << e;
  EXPECT_EQ(std::count(e.begin(), e.end(), '\n'), 1) << e;
  EXPECT_FALSE(fs::exists(dir / "out"));

  ASSERT_EQ(WEXITSTATUS(std::system((base + " --model '" + st.smplx.string() + "' --smpl-model '" +
                                     st.smpl.string() + "' --smpl-correspondence '" + st.corr.string() +
                                     "'" + redirect)
                                        .c_str())),
            0)
      << slurp(dir / "e.txt");
  std::printf("%s", slurp(dir / "o.txt").c_str());
  // Per-frame residual lines, each under 5 mm.
  std::istringstream out(slurp(dir / "o.txt"));
  int lines = 0;
  for (std::string line; std::getline(out, line);) {
    double jm = 0, vm = 0;
    int f = 0;
    if (std::sscanf(line.c_str(), "frame %d: residual joints %lf mm, vertices %lf mm", &f, &jm, &vm) == 3) {
      ++lines;
      EXPECT_LT(jm, 5.0) << line;
      EXPECT_LT(vm, 5.0) << line;
    }
  }
  EXPECT_EQ(lines, 3) << slurp(dir / "o.txt");
  // The known template shift is in the converted transl.
  const Dataset ds = read_dataset((dir / "out").string(), LoadPixels::headers);
  ASSERT_EQ(ds.frames.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    double d2 = 0;
    for (int k = 0; k < 3; ++k) d2 += std::pow(ds.frames[i].params.transl[size_t(k)] - (transl[i][size_t(k)] + so.shift[size_t(k)]), 2);
    EXPECT_LT(std::sqrt(d2), 0.005) << "frame " << i;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace haha
