// The cause of a log message: its text with the numbers taken out, so that
// the same fault with other figures counts once (track_bag's drop counts,
// and the log_flood rostest's count of lines per cause).
#pragma once

#include <string>

namespace imt::track_bag {

// The cause of a message: its text with every number (digits, a sign, a
// fraction, an exponent) written '#', so that "image data has 19200 bytes"
// and "image data has 4800 bytes" count as one cause.
inline std::string causeOf(const std::string& text) {
  std::string out;
  for (size_t i = 0; i < text.size();) {
    const auto digit = [&](size_t j) { return j < text.size() && text[j] >= '0' && text[j] <= '9'; };
    if (!digit(i)) {
      out += text[i++];
      continue;
    }
    while (digit(i) || (text[i] == '.' && digit(i + 1))) ++i;
    if (i < text.size() && (text[i] == 'e' || text[i] == 'E') &&
        (digit(i + 1) || ((text[i + 1] == '-' || text[i + 1] == '+') && digit(i + 2)))) {
      i += 2;
      while (digit(i)) ++i;
    }
    if (!out.empty() && (out.back() == '-' || out.back() == '+')) out.pop_back();
    out += '#';
  }
  return out;
}

}  // namespace imt::track_bag
