// Parsing JSON text for the readers of small JSON files (cam.json, keypoint files): one
// haha::Error line naming the file on malformed text, and no silent duplicate keys.
#pragma once

#include <exception>
#include <string>

#include <nlohmann/json.hpp>

namespace haha {

// nlohmann's message without its "[json.exception.xxx] " prefix.
std::string json_error_message(const std::exception& e);

// Parses `text`; fails "<where>: invalid JSON: ..." or "<where>: <key>: duplicate key" (a
// key repeated in the top-level object, which nlohmann would otherwise resolve silently).
nlohmann::json parse_json_text(const std::string& text, const std::string& where);

// A finite number; fails "<where>: <key>: expected a number, got <type>" / "value is not finite".
double json_number(const nlohmann::json& v, const std::string& where, const std::string& key);

// A number for error messages (9 significant digits).
std::string json_num_text(double v);

}  // namespace haha
