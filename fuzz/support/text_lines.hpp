// The most lines a YAML reader can count in a text: yaml-cpp breaks lines at LF, CR, CR LF and
// the Unicode breaks NEL (U+0085), LS (U+2028), PS (U+2029); counting each of them (CR LF
// twice) gives an upper bound for the line of any diagnostic of the text parsers' targets.
#pragma once

#include <string_view>

namespace drivecheck::fuzz {

inline int max_line_count(std::string_view text) {
  int lines = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n' || c == '\r') ++lines;
    if (text.substr(i, 2) == "\xC2\x85" || text.substr(i, 3) == "\xE2\x80\xA8" ||
        text.substr(i, 3) == "\xE2\x80\xA9")
      ++lines;
  }
  return lines;
}

}  // namespace drivecheck::fuzz
