// `haha render --model` with an avatar that carries a garment (body/garment.h): the body
// model is checked against the file's body part, supplies its correctives, and the
// garment reposes with its own weights; a model of another topology is still refused.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "body/procedural_body.h"
#include "format/avatar_pack.h"
#include "io/body_model_io.h"
#include "support/format_test_avatar.h"
#include "support/haha_cli.h"

namespace haha {
namespace {

namespace fs = std::filesystem;

int haha_cli(const std::string& args, const fs::path& dir, std::string* out) { return test::run_haha(args, dir, out); }
std::string q(const fs::path& p) { return test::quoted(p); }

TEST(RenderGarmentModel, ModelIsCheckedAgainstTheBodyPart) {
  if (!fs::exists(test::kHaha)) GTEST_SKIP() << "the haha executable is not built at " << test::kHaha;
  const fs::path dir = fs::temp_directory_path() / ("haha-render-garment-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  // The generated SMPL-X stand-in, and an avatar of it with the test garment appended and
  // a few Gaussians on each part; no correctives embedded, so --model supplies them.
  const BodyModel model = make_procedural_body({BodyResolution::low, 0});
  save_body_model(model, (dir / "model.npz").string());
  Avatar a = test::make_test_avatar(40);
  a.body = append_garment(model, test::make_test_garment());
  a.betas.clear();
  a.expression.clear();
  for (int i = 0; i < a.gaussians.size(); ++i)
    a.gaussians.face[size_t(i)] = i < 6 ? model.num_faces + i % 2 : (i * 37) % model.num_faces;
  PackOptions opt;
  opt.pose_correctives = PoseCorrectives::none;
  write_avatar_glb(a, (dir / "avatar.glb").string(), opt);

  std::string out;
  ASSERT_EQ(haha_cli("motion --out " + q(dir / "wave.npz") + " --kind wave", dir, &out), 0) << out;
  const std::string render = "render " + q(dir / "avatar.glb") + " --motion " + q(dir / "wave.npz") + " --size 32 --out ";
  EXPECT_EQ(haha_cli(render + q(dir / "frames") + " --model " + q(dir / "model.npz"), dir, &out), 0) << out;
  EXPECT_EQ(out.find("warning"), std::string::npos) << out;  // the correctives came from --model
  EXPECT_FALSE(fs::is_empty(dir / "frames"));

  // Another topology: refused, naming the model.
  const BodyModel other = make_procedural_body({BodyResolution::low, 1});
  BodyModel cut = other;
  cut.faces.resize(cut.faces.size() - 3);
  cut.ft.resize(cut.ft.size() - 3);
  cut.num_faces -= 1;
  save_body_model(cut, (dir / "other.npz").string());
  EXPECT_EQ(haha_cli(render + q(dir / "frames2") + " --model " + q(dir / "other.npz"), dir, &out), 1) << out;
  EXPECT_NE(out.find("other.npz"), std::string::npos) << out;
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
}  // namespace haha
