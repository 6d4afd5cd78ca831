// `haha synth --subject N`, --view-shading and --motion through the executable: an unknown
// subject, an out-of-range strength or a bad motion file is one error line and exit code 1,
// before anything is written.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <filesystem>
#include <string>

#include "support/haha_cli.h"

namespace {

namespace fs = std::filesystem;

using haha::test::kHaha;
using haha::test::slurp;

// Runs `haha synth ARGS --out DIR/out`, returns the exit code; stderr in *err.
int synth(const std::string& args, const fs::path& dir, std::string* err) {
  const fs::path e = dir / "err.txt";
  const std::string cmd = "'" + kHaha.string() + "' synth " + args + " --out '" + (dir / "out").string() +
                          "' > /dev/null 2> '" + e.string() + "'";
  const int status = std::system(cmd.c_str());
  *err = slurp(e);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(SynthSubjectCli, UnknownSubjectOrShadingIsOneLine) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-synth-subject-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::string err;
  EXPECT_EQ(synth("--subject 3 --size 16 --frames 1 --test-frames 0 --body-resolution low", dir, &err), 1);
  EXPECT_EQ(err, "haha: error: --subject: 3 is not a subject (expected 1 or 2)\n");
  EXPECT_EQ(synth("--subject 2 --view-shading 7 --size 16 --frames 1 --test-frames 0 --body-resolution low", dir, &err), 1);
  EXPECT_EQ(err.rfind("haha: error: --view-shading: must be in [0, 2]", 0), 0u) << err;
  EXPECT_EQ(err.find('\n'), err.size() - 1) << err;
  EXPECT_FALSE(fs::exists(dir / "out"));
  fs::remove_all(dir);
}

TEST(SynthSubjectCli, BadMotionFileIsOneLineNamingIt) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-synth-motion-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string bad = (dir / "bad.npz").string();
  std::ofstream(bad) << "not an npz";
  std::string err;
  EXPECT_EQ(synth("--motion '" + bad + "' --size 16 --body-resolution low", dir, &err), 1);
  EXPECT_EQ(err.rfind("haha: error: " + bad + ": ", 0), 0u) << err;
  EXPECT_EQ(err.find('\n'), err.size() - 1) << err;
  // Options of the turn do not go with --motion; thinning needs it.
  EXPECT_NE(synth("--motion '" + bad + "' --frames 3 --body-resolution low", dir, &err), 0);
  EXPECT_NE(synth("--every 2 --size 16 --body-resolution low", dir, &err), 0);
  EXPECT_FALSE(fs::exists(dir / "out"));
  fs::remove_all(dir);
}

}  // namespace
