#include "app/batch_manifest.h"

#include <cctype>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <set>

#include "core/atomic_file.h"
#include "core/error.h"
#include "train/config.h"

namespace haha {

namespace fs = std::filesystem;

namespace {

const std::set<std::string> kFitKeys = {"fps",    "test-every", "test-from", "focal",    "focal-35mm",
                                        "fov",    "frames",     "mask",      "keypoints", "robust-smoothness"};
const std::set<std::string> kEvalKeys = {"tto-steps", "frames", "split", "background", "antialias"};
const std::set<std::string> kPackKeys = {"mesh-compression", "texture",  "texture-size", "texture-quality",
                                         "lod",              "lossless", "khr-gaussian-splatting", "normals",
                                         "keep-face-order"};

bool valid_id(const std::string& id) {
  if (id.empty() || id.size() > 128 || id[0] == '.' || id[0] == '-') return false;
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) return false;
  return true;
}

bool is_number(const std::string& v, bool integer) {
  if (v.empty()) return false;
  char* end = nullptr;
  if (integer) {
    (void)std::strtoll(v.c_str(), &end, 10);
  } else {
    (void)std::strtod(v.c_str(), &end);
  }
  return end && *end == '\0';
}

std::string check_value(const std::string& group, const std::string& key, const std::string& v) {
  auto one_of = [&](std::initializer_list<const char*> ok) {
    for (const char* o : ok)
      if (v == o) return std::string();
    std::string list;
    for (const char* o : ok) list += std::string(list.empty() ? "" : " | ") + o;
    return "expected " + list + ", got '" + v + "'";
  };
  if (group == "fit") {
    if (key == "frames") return v.find(':') == std::string::npos ? "expected A:B:S, got '" + v + "'" : "";
    if (key == "mask") return one_of({"pose", "selfie"});
    if (key == "keypoints") return one_of({"accurate", "fast"});
    if (key == "test-every" || key == "test-from") return is_number(v, true) ? "" : "expected an integer, got '" + v + "'";
    return is_number(v, false) ? "" : "expected a number, got '" + v + "'";
  }
  if (group == "eval") {
    if (key == "split") return one_of({"train", "test", "none"});
    if (key == "background") return one_of({"black", "white"});
    if (key == "antialias") return one_of({"true", "false"});
    return is_number(v, true) ? "" : "expected an integer, got '" + v + "'";
  }
  if (key == "mesh-compression") return one_of({"draco", "none"});
  if (key == "texture") return one_of({"jpg", "png", "webp"});
  if (key == "lossless" || key == "khr-gaussian-splatting" || key == "normals" || key == "keep-face-order")
    return one_of({"true", "false"});
  return is_number(v, true) ? "" : "expected an integer, got '" + v + "'";
}

}  // namespace

std::vector<std::string> split_manifest_line(const std::string& line, std::string& error) {
  std::vector<std::string> out;
  size_t i = 0;
  const size_t n = line.size();
  while (i < n) {
    while (i < n && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    if (i >= n || line[i] == '#') break;
    std::string tok;
    bool any = false;
    while (i < n && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') {
      if (line[i] == '"') {
        any = true;
        ++i;
        bool closed = false;
        while (i < n) {
          if (line[i] == '\\' && i + 1 < n && (line[i + 1] == '"' || line[i + 1] == '\\')) {
            tok += line[i + 1];
            i += 2;
          } else if (line[i] == '"') {
            closed = true;
            ++i;
            break;
          } else {
            tok += line[i++];
          }
        }
        if (!closed) {
          error = "unterminated quote";
          return out;
        }
      } else {
        tok += line[i++];
        any = true;
      }
    }
    if (any) out.push_back(tok);
  }
  return out;
}

void resolve_subject_options(BatchSubject& s) {
  s.preset = "standard";
  s.device = "cpu";
  s.model.clear();
  s.train_overrides.clear();
  s.fit.clear(), s.eval.clear(), s.pack.clear();
  auto bad = [&](const std::string& what) {
    if (s.error.empty()) s.error = what;
  };
  for (const auto& [key, value] : s.options) {
    const size_t colon = key.find(':');
    if (colon != std::string::npos) {
      const std::string group = key.substr(0, colon), k = key.substr(colon + 1);
      const std::set<std::string>* keys = group == "fit" ? &kFitKeys : group == "eval" ? &kEvalKeys
                                          : group == "pack"                            ? &kPackKeys
                                                                                       : nullptr;
      if (!keys) {
        bad("option " + key + ": unknown prefix '" + group + ":' (fit:, eval: or pack:)");
        continue;
      }
      if (!keys->count(k)) {
        std::string list;
        for (const std::string& x : *keys) list += (list.empty() ? "" : ", ") + x;
        bad("option " + key + ": unknown " + group + ": option (" + list + ")");
        continue;
      }
      const std::string why = check_value(group, k, value);
      if (!why.empty()) {
        bad("option " + key + ": " + why);
        continue;
      }
      auto& dst = group == "fit" ? s.fit : group == "eval" ? s.eval : s.pack;
      bool replaced = false;
      for (auto& kv : dst)
        if (kv.first == k) kv.second = value, replaced = true;
      if (!replaced) dst.emplace_back(k, value);
    } else if (key == "preset") {
      s.preset = value;
    } else if (key == "device") {
      if (value != "cpu" && value != "cuda" && value != "auto")
        bad("option device: expected cpu | cuda | auto, got '" + value + "'");
      s.device = value;
    } else if (key == "model") {
      s.model = value;
    } else {
      s.train_overrides.push_back(key + "=" + value);
    }
  }
  if (!s.error.empty()) return;
  try {
    TrainConfig c = make_preset(s.preset);
    apply_overrides(c, s.train_overrides, "option");
    validate_config(c);
  } catch (const std::exception& e) {
    bad(e.what());
  }
}

std::string BatchSubject::fingerprint() const {
  // FNV-1a 64 over the fields, separated by NULs.
  uint64_t h = 1469598103934665603ull;
  auto add = [&](const std::string& t) {
    for (unsigned char c : t) h = (h ^ c) * 1099511628211ull;
    h = (h ^ 0u) * 1099511628211ull;
  };
  add(id);
  add(input);
  for (const auto& [k, v] : options) add(k), add(v);
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

BatchManifest parse_batch_manifest(const std::string& text, const std::string& path, const std::string& base_dir) {
  BatchManifest m;
  m.path = path;
  std::vector<std::pair<std::string, std::string>> defaults;
  std::vector<BatchSubject> subjects;
  std::set<std::string> ids;
  size_t pos = 0;
  int line_no = 0;
  auto parse_options = [](const std::vector<std::string>& toks, size_t from,
                          std::vector<std::pair<std::string, std::string>>& out, std::string& error) {
    for (size_t i = from; i < toks.size(); ++i) {
      const size_t eq = toks[i].find('=');
      if (eq == std::string::npos || eq == 0) {
        if (error.empty()) error = "option '" + toks[i] + "': expected key=value";
        continue;
      }
      out.emplace_back(toks[i].substr(0, eq), toks[i].substr(eq + 1));
    }
  };
  while (pos <= text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    const std::string line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    std::string error;
    const std::vector<std::string> toks = split_manifest_line(line, error);
    if (toks.empty() && error.empty()) continue;
    if (!toks.empty() && toks[0] == "*") {
      std::string derr;
      parse_options(toks, 1, defaults, derr);
      if (!error.empty() || !derr.empty())
        fail(path + ":" + std::to_string(line_no), (error.empty() ? derr : error) + " (a defaults line)");
      continue;
    }
    BatchSubject s;
    s.index = int(subjects.size());
    s.line = line_no;
    s.id = toks.size() > 0 ? toks[0] : "";
    s.input = toks.size() > 1 ? toks[1] : "";
    if (error.empty()) {
      if (!valid_id(s.id))
        error = "id '" + s.id + "': expected letters, digits, '.', '_' or '-' (not first: '.', '-')";
      else if (ids.count(s.id))
        error = "id '" + s.id + "' appears on an earlier line";
      else if (toks.size() < 2)
        error = "no input (expected: ID INPUT [key=value ...])";
    }
    if (!s.id.empty()) ids.insert(s.id);
    if (toks.size() > 2) parse_options(toks, 2, s.options, error);
    s.error = error.empty() ? "" : path + ":" + std::to_string(line_no) + ": " + error;
    subjects.push_back(std::move(s));
  }
  for (BatchSubject& s : subjects) {
    std::vector<std::pair<std::string, std::string>> own = std::move(s.options);
    s.options = defaults;
    s.options.insert(s.options.end(), own.begin(), own.end());
    if (!s.input.empty()) {
      const fs::path in(s.input);
      s.input_path = (in.is_absolute() ? in : fs::path(base_dir) / in).lexically_normal().string();
    }
    if (s.error.empty()) {
      resolve_subject_options(s);
      if (!s.error.empty()) s.error = path + ":" + std::to_string(s.line) + ": " + s.error;
    }
  }
  m.subjects = std::move(subjects);
  return m;
}

BatchManifest read_batch_manifest(const std::string& path) {
  if (!fs::is_regular_file(path)) fail(path, "manifest not found");
  const std::string text = read_text_file(path);
  const fs::path base = fs::absolute(path).parent_path();
  return parse_batch_manifest(text, path, base.string());
}

int batch_task_index(int index, const std::function<const char*(const char*)>& getenv_fn) {
  if (index >= 0) return index;
  for (const char* var : {"SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"}) {
    const char* v = getenv_fn(var);
    if (!v || !*v) continue;
    const std::string s(v);
    if (!is_number(s, true) || s[0] == '-') fail(var, "expected a non-negative integer, got '" + s + "'");
    return std::atoi(v);
  }
  return -1;
}

}  // namespace haha
