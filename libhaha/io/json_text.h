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

}  // namespace haha
