// Small text helpers shared by the readers and the command line.
#pragma once

#include <string>

namespace haha {

// ASCII lower case, independent of the locale (file extensions, keywords): "PNG" -> "png".
inline std::string ascii_lower(std::string s) {
  for (char& c : s)
    if (c >= 'A' && c <= 'Z') c = char(c - 'A' + 'a');
  return s;
}

}  // namespace haha
