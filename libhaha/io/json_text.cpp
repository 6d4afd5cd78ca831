#include "io/json_text.h"

#include <cmath>
#include <set>
#include <sstream>

#include "core/error.h"

namespace haha {

std::string json_error_message(const std::exception& e) {
  std::string m = e.what();
  const auto p = m.find("] ");
  return p == std::string::npos ? m : m.substr(p + 2);
}

nlohmann::json parse_json_text(const std::string& text, const std::string& where) {
  using json = nlohmann::json;
  std::set<std::string> seen;
  std::string dup;
  json::parser_callback_t cb = [&](int depth, json::parse_event_t ev, json& parsed) {
    if (ev == json::parse_event_t::key && depth == 1 && !seen.insert(parsed.get<std::string>()).second && dup.empty())
      dup = parsed.get<std::string>();
    return true;
  };
  json root;
  try {
    root = json::parse(text, cb);
  } catch (const std::exception& e) {
    fail(where, "invalid JSON: " + json_error_message(e));
  }
  if (!dup.empty()) fail(where, dup + ": duplicate key");
  return root;
}

double json_number(const nlohmann::json& v, const std::string& where, const std::string& key) {
  if (!v.is_number()) fail(where, key + ": expected a number, got " + std::string(v.type_name()));
  const double d = v.get<double>();
  if (!std::isfinite(d)) fail(where, key + ": value is not finite");
  return d;
}

std::string json_num_text(double v) {
  std::ostringstream s;
  s.precision(9);
  s << v;
  return s.str();
}

}  // namespace haha
