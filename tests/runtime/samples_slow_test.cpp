// The install package and the samples, end to end, with the commands docs/embedding.md
// documents: `cmake --install` into a temporary prefix (only the runtime lands there, and
// the library's dependencies resolve from the system), samples/c built with one `cc` line
// through pkg-config, samples/cpp built with find_package(haha); both run on a small
// avatar and motion and write valid PNG frames.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "format/avatar_pack.h"
#include "io/image.h"
#include "io/npy.h"
#include "support/runtime_sample_inputs.h"

namespace fs = std::filesystem;

namespace haha {
namespace {

using test::q;
using test::sh;

using SampleTempDir = test::SampleTempDir;

// Frames exist, are valid PNGs of the size asked and show the body (not only background).
void expect_frames(const fs::path& dir, int count, int size) {
  for (int f = 0; f < count; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%05d.png", f);
    const fs::path p = dir / name;
    ASSERT_TRUE(fs::exists(p)) << p;
    const Image img = read_image(p.string());
    EXPECT_EQ(img.width, size);
    EXPECT_EQ(img.height, size);
    EXPECT_EQ(img.channels, 3);
    int body = 0;
    for (float v : img.data) body += v < 0.95f;  // the background is white
    EXPECT_GT(body, size * size / 50) << p << ": the frame shows no body";
  }
  EXPECT_FALSE(fs::exists(dir / "frame_00003.png"));
}

TEST(RuntimeSamples, InstallThenBuildAndRunTheSamplesAgainstThePrefix) {
  SampleTempDir tmp("haha_samples");
  const fs::path prefix = tmp.path / "prefix", src = HAHA_SOURCE_DIR;
  const fs::path glb = tmp.path / "avatar.glb", motion = tmp.path / "motion.npz";
  test::write_sample_inputs(glb, motion);
  std::string out;

  // Install: only the runtime package.
  ASSERT_EQ(sh(std::string("'") + HAHA_CMAKE_COMMAND + "' --install '" + HAHA_BINARY_DIR + "' --prefix " + q(prefix), &out), 0)
      << out;
  std::set<std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(prefix))
    if (!e.is_directory()) files.insert(e.path().lexically_relative(prefix).string());
  for (const char* f : {"include/haha/haha_runtime.h", "lib/libhaha_runtime.so", "lib/cmake/haha/hahaConfig.cmake",
                        "lib/cmake/haha/hahaConfigVersion.cmake", "lib/cmake/haha/hahaTargets.cmake",
                        "lib/pkgconfig/haha_runtime.pc", "lib/python/haha/__init__.py"})
    EXPECT_TRUE(files.count(f)) << f << " not installed";
  for (const std::string& f : files) {
    const bool python = f.rfind("lib/python/haha/", 0) == 0 && f.size() > 3 && f.substr(f.size() - 3) == ".py";
    const bool expected = f == "include/haha/haha_runtime.h" || f.rfind("lib/libhaha_runtime.so", 0) == 0 ||
                          f.rfind("lib/cmake/haha/haha", 0) == 0 || f == "lib/pkgconfig/haha_runtime.pc" || python ||
                          f.rfind("share/haha/blender/addons/io_import_haha_avatar/", 0) == 0;
    EXPECT_TRUE(expected) << "unexpected file in the install: " << f;
  }
  // A versioned SONAME, and every dependency resolves from the system.
  ASSERT_EQ(sh("objdump -p " + q(prefix / "lib/libhaha_runtime.so") + " | grep SONAME", &out), 0) << out;
  EXPECT_NE(out.find("libhaha_runtime.so.0."), std::string::npos) << out;
  ASSERT_EQ(sh("ldd " + q(prefix / "lib/libhaha_runtime.so"), &out), 0) << out;
  EXPECT_EQ(out.find("not found"), std::string::npos) << out;

  // The Python package beside the library finds it there (skipped without Debian's python3-numpy).
  if (sh("/usr/bin/python3 -c 'import numpy'", &out) == 0) {
    const std::string py = "/usr/bin/python3 -c \"import sys; sys.path.insert(0, '" + (prefix / "lib/python").string() +
                           "'); import haha; print(haha.library_path()); print(haha.Avatar('" + glb.string() +
                           "').num_gaussians, 'Gaussians')\"";
    ASSERT_EQ(sh("env -u HAHA_RUNTIME_LIBRARY " + py, &out), 0) << py << "\n" << out;
    EXPECT_NE(out.find((prefix / "lib/libhaha_runtime.so").string()), std::string::npos) << out;
    EXPECT_NE(out.find("300 Gaussians"), std::string::npos) << out;
  } else {
    std::printf("note: /usr/bin/python3 without numpy: the installed Python package is not checked\n");
  }

  // samples/c with the one documented command (docs/embedding.md), run from the source tree.
  const fs::path sample_c = tmp.path / "haha_sample_c";
  const std::string build_c = "cd " + q(src) + " && export PKG_CONFIG_PATH=" + q(prefix / "lib/pkgconfig") +
                              " && cc -std=c99 -O2 samples/c/haha_sample_c.c $(pkg-config --cflags --libs haha_runtime)"
                              " -Wl,-rpath,$(pkg-config --variable=libdir haha_runtime) -o " + q(sample_c);
  ASSERT_EQ(sh(build_c, &out), 0) << build_c << "\n" << out;
  ASSERT_EQ(sh(q(sample_c) + " " + q(glb) + " " + q(motion) + " " + q(tmp.path / "frames_c") + " 64", &out), 0) << out;
  EXPECT_NE(out.find("frame     2: repose"), std::string::npos) << out;
  EXPECT_NE(out.find("3 frames 64x64: mean repose"), std::string::npos) << out;
  expect_frames(tmp.path / "frames_c", 3, 64);
  // Bad input: a clear message and a non-zero exit, no crash.
  EXPECT_NE(sh(q(sample_c) + " " + q(motion) + " " + q(motion) + " " + q(tmp.path / "bad"), &out), 0);
  EXPECT_NE(out.find("load avatar: HAHA_ERROR_FORMAT: " + motion.string() + ": "), std::string::npos) << out;

  // samples/cpp: a standalone CMake project finding the package.
  const fs::path build_dir = tmp.path / "sample-cpp";
  const std::string build_cpp = "cmake -S " + q(src / "samples/cpp") + " -B " + q(build_dir) +
                                " -DCMAKE_PREFIX_PATH=" + q(prefix) + " -DCMAKE_BUILD_TYPE=Release && cmake --build " +
                                q(build_dir);
  ASSERT_EQ(sh(build_cpp, &out), 0) << build_cpp << "\n" << out;
  ASSERT_EQ(sh(q(build_dir / "haha_sample_cpp") + " " + q(glb) + " " + q(motion) + " --builtin-render " +
                   q(tmp.path / "frames_cpp") + " --size 64",
               &out),
            0)
      << out;
  EXPECT_NE(out.find("frame     2: repose+readback"), std::string::npos) << out;
  EXPECT_NE(out.find("300 Gaussians"), std::string::npos) << out;
  expect_frames(tmp.path / "frames_cpp", 3, 64);
}

}  // namespace
}  // namespace haha
