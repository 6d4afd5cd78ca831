// `haha info` reports the texture's speckle where the video barely looked
// (render/texture_speckle.h): in the text and the JSON summary, and not for an avatar
// without a texture.
#include <gtest/gtest.h>

#include <string>

#include "format/avatar_info.h"
#include "render/texture_charts.h"
#include "support/low_body.h"

using namespace haha;

TEST(AvatarInfoSpeckle, TextAndJsonCarryTheMeasure) {
  UnpackedAvatar u;
  u.avatar.body = test::low_body();
  const int S = 64;
  u.avatar.texture.width = u.avatar.texture.height = S;
  u.avatar.texture.rgb.assign(size_t(S) * S * 3, 0.5f);
  // One white texel in every 16 chart texels: about 62.5 per mille everywhere.
  const TextureCharts c = texture_charts(u.avatar.body, S, S);
  int64_t n = 0;
  for (size_t t = 0; t < c.face.size(); ++t)
    if (c.face[t] >= 0 && n++ % 16 == 0)
      for (int ch = 0; ch < 3; ++ch) u.avatar.texture.rgb[3 * t + ch] = 1.0f;
  const auto sp = avatar_texture_speckle(u.avatar);
  ASSERT_TRUE(sp.has_value());
  EXPECT_NEAR(sp->all_per_mille, 62.5, 5.0);  // chart borders with few neighbours shift it a little
  const StorageReport r;
  const nlohmann::json j = avatar_summary_json("a.glb", u, r);
  ASSERT_TRUE(j["texture"].contains("speckle")) << j["texture"].dump();
  for (const char* part : {"neck", "hands", "feet"})
    EXPECT_GT(j["texture"]["speckle"]["perMille"][part].get<double>(), 0.0) << part;
  EXPECT_DOUBLE_EQ(j["texture"]["speckle"]["perMille"]["allCharts"].get<double>(), sp->all_per_mille);
  const std::string text = avatar_summary_text("a.glb", u, r);
  EXPECT_NE(text.find("speckle       neck "), std::string::npos) << text;

  u.avatar.texture = {};  // no texture: no measure, no line
  EXPECT_FALSE(avatar_texture_speckle(u.avatar).has_value());
  EXPECT_FALSE(avatar_summary_json("a.glb", u, r)["texture"].contains("speckle"));
  EXPECT_EQ(avatar_summary_text("a.glb", u, r).find("speckle"), std::string::npos);
}
