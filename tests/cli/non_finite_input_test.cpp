// NaN, Inf and out-of-range values in every kind of input (fits, frames and masks, cameras,
// body models, Gaussians, motions) through the `haha` command: each is refused before any
// work with exit code 1 and one line naming the file and the field, and no output appears.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "format/avatar_pack.h"
#include "io/image.h"
#include "io/npy.h"
#include "support/format_test_avatar.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

using haha::test::kHaha;
using haha::test::slurp;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

// Runs haha; returns the exit code, stderr in `err`.
int run_haha(const std::vector<std::string>& args, const fs::path& err_file, std::string& err) {
  std::string cmd = "'" + kHaha.string() + "'";
  for (const std::string& a : args) cmd += " '" + a + "'";
  cmd += " > /dev/null 2> '" + err_file.string() + "'";
  const int status = std::system(cmd.c_str());
  err = slurp(err_file);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Rewrites one value of an array in an .npz (keeping its dtype: f32 or f64).
void poison_npz(const fs::path& path, const std::string& key, size_t index, double value) {
  Npz z = Npz::read(path.string());
  const NpyArray a = z.get(key);
  if (a.dtype == DType::f64) {
    std::vector<double> v = a.as_double();
    v.at(index) = value;
    z.set(key, NpyArray::from(v, a.shape));
  } else {
    std::vector<float> v = a.as_float();
    v.at(index) = float(value);
    z.set(key, NpyArray::from(v, a.shape));
  }
  z.write(path.string());
}

void edit_json(const fs::path& path, const std::function<void(nlohmann::ordered_json&)>& edit) {
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(slurp(path));
  edit(j);
  std::ofstream(path) << j.dump(1);
}

class NonFiniteInput : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!fs::exists(kHaha)) return;
    root_ = fs::temp_directory_path() / ("haha-nonfinite-" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
    std::string err;
    ASSERT_EQ(run_haha({"synth", "--out", (root_ / "data").string(), "--size", "24", "--frames", "3", "--test-frames",
                        "1", "--body-resolution", "low", "--supersample", "1"},
                       root_ / "err.txt", err),
              0)
        << err;
    ASSERT_EQ(run_haha({"motion", "--out", (root_ / "motion.npz").string(), "--frames", "3"}, root_ / "err.txt", err), 0)
        << err;
    write_avatar_glb(test::make_test_avatar(50), (root_ / "avatar.glb").string(), PackOptions{});
  }
  static void TearDownTestSuite() { fs::remove_all(root_); }

  void SetUp() override {
    if (!fs::exists(kHaha)) GTEST_SKIP() << "the haha executable is not built at " << kHaha;
    dir_ = root_ / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::create_directories(dir_);
    fs::copy(root_ / "data", dir_ / "data", fs::copy_options::recursive);
    fs::copy_file(root_ / "motion.npz", dir_ / "motion.npz");
  }

  // `args` must end in exit code 1 with one line naming `file` and every needle, and leave
  // `output` absent.
  void expect_refused(const std::vector<std::string>& args, const fs::path& file,
                      const std::vector<std::string>& needles, const fs::path& output) {
    std::string err;
    const int code = run_haha(args, dir_ / "err.txt", err);
    EXPECT_EQ(code, 1) << err;
    EXPECT_EQ(err.rfind("haha: error: ", 0), 0u) << err;
    EXPECT_EQ(err.find('\n'), err.size() - 1) << "one line: " << err;
    EXPECT_NE(err.find(file.string()), std::string::npos) << "names " << file << ": " << err;
    for (const std::string& n : needles) EXPECT_NE(err.find(n), std::string::npos) << "says '" << n << "': " << err;
    EXPECT_FALSE(fs::exists(output)) << output;
  }
  std::vector<std::string> train_args() const {
    return {"train", "--data", (dir_ / "data").string(), "--out", (dir_ / "run").string(), "--preset", "tiny",
            "resolution=24", "s1.steps=2", "s2.steps=2", "s3.steps=2"};
  }
  // A frame or mask replaced by a float EXR holding `value` at pixel (3, 2).
  fs::path float_image(const std::string& kind, int channels, float value) {
    const fs::path rel = fs::path(kind) / "000001.exr";
    // Written with OpenImageIO directly: write_image refuses non-finite pixels.
    std::vector<float> px(size_t(24 * 24 * channels), 0.5f);
    px[size_t((2 * 24 + 3) * channels)] = value;
    const std::string path = (dir_ / "data" / rel).string();
    auto out = OIIO::ImageOutput::create(path);
    EXPECT_TRUE(out && out->open(path, OIIO::ImageSpec(24, 24, channels, OIIO::TypeDesc::FLOAT)));
    EXPECT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, px.data()));
    out->close();
    edit_json(dir_ / "data" / "dataset.json",
              [&](auto& j) { j["frames"][1][kind == "images" ? "image" : "mask"] = rel.string(); });
    return dir_ / "data" / rel;
  }

  static fs::path root_;
  fs::path dir_;
};

fs::path NonFiniteInput::root_;

TEST_F(NonFiniteInput, FitsWithNaNOrInf) {
  const fs::path params = dir_ / "data" / "smplx" / "params.npz";
  poison_npz(params, "body_pose", 5, kNaN);
  expect_refused(train_args(), params, {"body_pose", "non-finite value in frame 0"}, dir_ / "run");
  poison_npz(params, "body_pose", 5, 0.0);
  poison_npz(params, "transl", 4, kInf);
  expect_refused(train_args(), params, {"transl", "non-finite value in frame 1"}, dir_ / "run");
}

TEST_F(NonFiniteInput, FramesAndMasksWithNaNInfOrValuesOutsideZeroOne) {
  fs::path f = float_image("images", 3, kNaN);
  expect_refused(train_args(), f, {"non-finite value at pixel (3, 2)"}, dir_ / "run");
  f = float_image("images", 3, -kInf);
  expect_refused(train_args(), f, {"non-finite value at pixel (3, 2)"}, dir_ / "run");
  f = float_image("images", 3, 1.5f);
  expect_refused(train_args(), f, {"1.5", "at pixel (3, 2) is outside [0, 1]"}, dir_ / "run");
  float_image("images", 3, 0.5f);  // a good frame again
  f = float_image("masks", 1, -0.25f);
  expect_refused(train_args(), f, {"-0.25", "at pixel (3, 2) is outside [0, 1]"}, dir_ / "run");
}

TEST_F(NonFiniteInput, CamerasOutOfRange) {
  const fs::path json = dir_ / "data" / "dataset.json";
  edit_json(json, [](auto& j) { j["camera"]["K"][0][0] = -40.0; });
  expect_refused(train_args(), json, {"camera: K: focal length K[0][0] must be > 0"}, dir_ / "run");
  // JSON has no NaN or Inf; a number too large for a double is refused by the parser.
  std::string text = slurp(json);
  text.replace(text.find("-40"), 3, "1e999");
  std::ofstream(json) << text;
  expect_refused(train_args(), json, {"number overflow"}, dir_ / "run");

  const fs::path cam = dir_ / "cam.json";
  std::ofstream(cam) << R"({"width": 32, "height": 32, "K": [[40, 0, 16], [0, 40, 16], [0, 0, 1]],
    "world_to_camera": [[1, 0, 0, 0], [0, -1, 0, 0], [0, 0, -1, 3], [0, 0, 0, 1]], "near": -1, "far": 10})";
  expect_refused({"render", (root_ / "avatar.glb").string(), "--motion", (dir_ / "motion.npz").string(), "--camera",
                  cam.string(), "--out", (dir_ / "frames").string()},
                 cam, {"near"}, dir_ / "frames");
}

TEST_F(NonFiniteInput, BodyModelWithNaN) {
  const fs::path model = dir_ / "data" / "body_model.npz";
  poison_npz(model, "v_template", 7, kNaN);
  std::vector<std::string> args = train_args();
  args.insert(args.end(), {"--model", model.string()});
  expect_refused(args, model, {"v_template", "non-finite value at flat index 7"}, dir_ / "run");
}

TEST_F(NonFiniteInput, GaussiansWithNaN) {
  const fs::path ply = dir_ / "scene.ply", cam = dir_ / "cam.json";
  std::ofstream(ply) << "ply\nformat ascii 1.0\nelement vertex 2\n"
                        "property float x\nproperty float y\nproperty float z\n"
                        "property float f_dc_0\nproperty float f_dc_1\nproperty float f_dc_2\n"
                        "property float opacity\nproperty float scale_0\nproperty float scale_1\nproperty float scale_2\n"
                        "property float rot_0\nproperty float rot_1\nproperty float rot_2\nproperty float rot_3\n"
                        "end_header\n0 0 0 1 1 1 2 -3 -3 -3 1 0 0 0\n0 0 0 1 1 1 nan -3 -3 -3 1 0 0 0\n";
  std::ofstream(cam) << R"({"width": 32, "height": 32, "K": [[40, 0, 16], [0, 40, 16], [0, 0, 1]],
    "world_to_camera": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 3], [0, 0, 0, 1]]})";
  expect_refused({"render-ply", ply.string(), "--camera", cam.string(), "--out", (dir_ / "out.png").string()}, ply,
                 {"vertex 1", "opacity", "not finite"}, dir_ / "out.png");
}

TEST_F(NonFiniteInput, MotionsWithNaNInfOrABadRate) {
  const fs::path motion = dir_ / "motion.npz";
  const std::vector<std::string> args = {"render", (root_ / "avatar.glb").string(), "--motion", motion.string(),
                                         "--out", (dir_ / "frames").string(), "--size", "32"};
  const Npz z = Npz::read(motion.string());
  for (const std::string& key : z.keys()) {
    if (z.get(key).dtype != DType::f32 && z.get(key).dtype != DType::f64) continue;
    SCOPED_TRACE(key);
    fs::copy_file(root_ / "motion.npz", motion, fs::copy_options::overwrite_existing);
    poison_npz(motion, key, 0, kNaN);
    expect_refused(args, motion, {key, "non-finite"}, dir_ / "frames");
  }
  fs::copy_file(root_ / "motion.npz", motion, fs::copy_options::overwrite_existing);
  poison_npz(motion, "mocap_frame_rate", 0, 0.0);
  expect_refused(args, motion, {"mocap_frame_rate", "frame rate must be positive"}, dir_ / "frames");
}

}  // namespace
}  // namespace haha
