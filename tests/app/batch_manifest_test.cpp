// The batch manifest (app/batch_manifest.h): tokens and quotes, defaults lines, options per
// stage, per-line errors that leave the other subjects valid, the task index from the
// scheduler's variables.
#include "app/batch_manifest.h"

#include <gtest/gtest.h>

#include <map>
#include <string>

#include "core/error.h"

namespace haha {
namespace {

TEST(BatchManifest, TokensQuotesAndComments) {
  std::string err;
  EXPECT_EQ(split_manifest_line("  a  b\tc # d e", err), (std::vector<std::string>{"a", "b", "c"}));
  EXPECT_EQ(split_manifest_line("id \"my clip.mp4\" k=\"x y\" q=\"a\\\"b\\\\\"", err),
            (std::vector<std::string>{"id", "my clip.mp4", "k=x y", "q=a\"b\\"}));
  EXPECT_TRUE(err.empty());
  EXPECT_TRUE(split_manifest_line("   # only a comment", err).empty());
  EXPECT_EQ(split_manifest_line("id \"#not a comment\"", err), (std::vector<std::string>{"id", "#not a comment"}));
  split_manifest_line("id \"open", err);
  EXPECT_NE(err.find("unterminated quote"), std::string::npos);
}

TEST(BatchManifest, SubjectsDefaultsAndOptions) {
  const std::string text =
      "# subjects\n"
      "* preset=tiny s1.steps=30 eval:tto-steps=0\n"
      "\n"
      "alice  clips/alice.mp4  fit:fps=10 fit:test-every=5\n"
      "bob    /data/bob        s1.steps=40 device=auto pack:mesh-compression=none eval:split=none\r\n"
      "carol  frames/carol     model=body.npz\n";
  const BatchManifest m = parse_batch_manifest(text, "m.txt", "/base");
  ASSERT_EQ(m.subjects.size(), 3u);
  const BatchSubject& a = m.subjects[0];
  EXPECT_EQ(a.index, 0);
  EXPECT_EQ(a.line, 4);
  EXPECT_EQ(a.id, "alice");
  EXPECT_EQ(a.input_path, "/base/clips/alice.mp4");
  EXPECT_TRUE(a.error.empty()) << a.error;
  EXPECT_EQ(a.preset, "tiny");
  EXPECT_EQ(a.train_overrides, (std::vector<std::string>{"s1.steps=30"}));
  ASSERT_EQ(a.fit.size(), 2u);
  EXPECT_EQ(a.fit[0], (std::pair<std::string, std::string>{"fps", "10"}));
  ASSERT_EQ(a.eval.size(), 1u);
  EXPECT_EQ(a.eval[0].first, "tto-steps");
  const BatchSubject& b = m.subjects[1];
  EXPECT_TRUE(b.error.empty()) << b.error;
  EXPECT_EQ(b.input_path, "/data/bob");
  EXPECT_EQ(b.device, "auto");
  // Its own line comes after the defaults: the later key wins when the trainer applies them.
  EXPECT_EQ(b.train_overrides, (std::vector<std::string>{"s1.steps=30", "s1.steps=40"}));
  ASSERT_EQ(b.pack.size(), 1u);
  EXPECT_EQ(b.pack[0].second, "none");
  EXPECT_EQ(m.subjects[2].model, "body.npz");
  EXPECT_EQ(m.subjects[2].index, 2);
  // Fingerprints tell lines apart and are stable.
  EXPECT_NE(a.fingerprint(), b.fingerprint());
  EXPECT_EQ(a.fingerprint(), parse_batch_manifest(text, "m.txt", "/elsewhere").subjects[0].fingerprint());
  EXPECT_EQ(a.fingerprint().size(), 16u);
}

TEST(BatchManifest, ABadLineIsThatSubjectsBadInputOnly) {
  const std::string text =
      "good  data/a\n"
      "bad-key  data/b  s1.stepz=4\n"
      "bad-value  data/c  s1.steps=-3\n"
      "bad-fit  video.mp4  fit:speed=2\n"
      "bad-prefix  video.mp4  render:size=2\n"
      "bad-eval  data/d  eval:split=val\n"
      "no-input\n"
      "good  data/e\n"
      "b@d  data/f\n"
      "noeq  data/g  justaword\n"
      "quote  \"data/h\n"
      "good2  data/i  pack:lossless=true pack:texture=png\n";
  const BatchManifest m = parse_batch_manifest(text, "m.txt", "/base");
  ASSERT_EQ(m.subjects.size(), 12u);
  std::map<std::string, std::string> want = {
      {"bad-key", "s1.stepz"},        {"bad-value", "s1.steps"},  {"bad-fit", "fit:speed"},
      {"bad-prefix", "render:"},      {"bad-eval", "eval:split"}, {"no-input", "no input"},
      {"b@d", "id 'b@d'"},            {"noeq", "justaword"},      {"quote", "unterminated quote"}};
  EXPECT_TRUE(m.subjects[0].error.empty()) << m.subjects[0].error;
  EXPECT_TRUE(m.subjects[11].error.empty()) << m.subjects[11].error;
  for (const BatchSubject& s : m.subjects) {
    if (s.index == 7) {
      EXPECT_NE(s.error.find("appears on an earlier line"), std::string::npos) << s.error;
      continue;
    }
    auto it = want.find(s.id);
    if (it == want.end()) continue;
    EXPECT_NE(s.error.find(it->second), std::string::npos) << s.id << ": " << s.error;
    EXPECT_EQ(s.error.rfind("m.txt:" + std::to_string(s.line) + ": ", 0), 0u) << s.error;
  }
  // A defaults line that does not parse makes the whole manifest unusable.
  EXPECT_THROW(parse_batch_manifest("* justaword\na data/a\n", "m.txt", "/"), Error);
}

TEST(BatchManifest, TaskIndexFromTheSchedulersVariables) {
  std::map<std::string, std::string> env;
  auto get = [&](const char* k) -> const char* {
    auto it = env.find(k);
    return it == env.end() ? nullptr : it->second.c_str();
  };
  EXPECT_EQ(batch_task_index(-1, get), -1);
  EXPECT_EQ(batch_task_index(4, get), 4);
  env["JOB_COMPLETION_INDEX"] = "2";
  EXPECT_EQ(batch_task_index(-1, get), 2);
  env["SLURM_ARRAY_TASK_ID"] = "7";
  EXPECT_EQ(batch_task_index(-1, get), 7);  // Slurm's first
  EXPECT_EQ(batch_task_index(0, get), 0);   // --index wins
  env["SLURM_ARRAY_TASK_ID"] = "x1";
  EXPECT_THROW(batch_task_index(-1, get), Error);
}

}  // namespace
}  // namespace haha
