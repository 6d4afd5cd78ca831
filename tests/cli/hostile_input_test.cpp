// Hostile inputs through the `haha` command: a header that claims far more than its file
// holds ends with exit code 1 and one line naming the file, under a 1 GB address-space
// limit (an allocation for the claimed size would fail the limit instead).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "support/haha_cli.h"

namespace {

namespace fs = std::filesystem;

using haha::test::kHaha;
using haha::test::slurp;

TEST(HostileInput, TwoBillionGaussianPlyIsOneLineAndExitCodeOne) {
  if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-hostile-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path ply = dir / "huge.ply", cam = dir / "cam.json", out = dir / "out.png", err = dir / "err.txt";
  {
    std::ofstream f(ply, std::ios::binary);
    f << "ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\n";
    for (const char* p : {"x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
                          "rot_0", "rot_1", "rot_2", "rot_3"})
      f << "property float " << p << "\n";
    f << "end_header\n" << std::string(1024, '\0');
  }
  std::ofstream(cam) << R"({"width": 64, "height": 64, "K": [[64, 0, 32], [0, 64, 32], [0, 0, 1]],
    "world_to_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 3], [0, 0, 0, 1]]})";
  // AddressSanitizer reserves terabytes of shadow address space, so a sanitizer build runs
  // without the limit; its allocator then aborts on the huge allocation instead.
#if defined(__SANITIZE_ADDRESS__)
  const std::string limit = "";
#else
  const std::string limit = "ulimit -v 1048576; ";
#endif
  const std::string cmd = limit + "'" + kHaha.string() + "' render-ply '" + ply.string() + "' --camera '" +
                          cam.string() + "' --out '" + out.string() + "' > /dev/null 2> '" + err.string() + "'";
  const int status = std::system(("bash -c \"" + cmd + "\"").c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string msg = slurp(err);
  EXPECT_EQ(msg.rfind("haha: error: " + ply.string() + ": element vertex: 2000000000 vertices cannot fit", 0), 0u) << msg;
  EXPECT_EQ(msg.find('\n'), msg.size() - 1) << "one line: " << msg;
  EXPECT_FALSE(fs::exists(out));
  fs::remove_all(dir);
}

}  // namespace
