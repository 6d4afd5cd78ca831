// tools/keypoints per-frame JSON (io/keypoints_json.h).
#include "fuzz_target.h"
#include "io/keypoints_json.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  haha::fuzz::expect_result_or_error([&] { (void)haha::parse_keypoints_json(text, "fuzz/000000.json"); });
  return 0;
}

void haha_fuzz_write_seeds(const std::filesystem::path& dir) {
  auto rows = [](int n, double x, double y, double s) {
    std::string out = "[";
    for (int i = 0; i < n; ++i)
      out += (i ? ",[" : "[") + std::to_string(x + i) + "," + std::to_string(y + i) + "," + std::to_string(s) + "]";
    return out + "]";
  };
  const std::string person = R"({"format":"haha-keypoints","version":1,"frame":"000000.png","width":64,"height":48,)"
                             R"("people":1,"score":0.9,"body":)" + rows(33, 10, 5, 0.8) + R"(,"body_world":)" +
                             rows(33, -0.5, -0.9, 0.01) + R"(,"left_hand":)" + rows(21, 30, 20, 0.7) +
                             R"(,"right_hand":null,"mask":"masks/000000.png","model":"m"})";
  haha::fuzz::write_seed(dir, "person.json", std::vector<uint8_t>(person.begin(), person.end()));
  const std::string nobody = R"({"format":"haha-keypoints","version":1,"frame":"a.jpg","width":8,"height":8,"people":0,)"
                             R"("score":0,"body":null,"body_world":null,"left_hand":null,"right_hand":null,"mask":null,"model":""})";
  haha::fuzz::write_seed(dir, "nobody.json", std::vector<uint8_t>(nobody.begin(), nobody.end()));
}
