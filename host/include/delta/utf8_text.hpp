// Text for messages and JSON replies: bytes that are not UTF-8 (a Latin-1 file name, a stray 0xFF
// in a CSV) shown as \xHH, so that terminals, logs and JSON encoders get text they can carry.
#pragma once

#include <cstdio>
#include <string>

namespace delta {

// Text as valid UTF-8: each byte that is not part of a well-formed UTF-8 sequence shown as \xHH.
inline std::string escape_invalid_utf8(const std::string& text) {
  std::string shown;
  shown.reserve(text.size());
  for (std::size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    std::size_t length = c < 0x80 ? 1 : (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 0;
    if (length > 1 && i + length <= text.size()) {
      const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[i + k]); };
      bool ok = true;
      for (std::size_t k = 1; k < length; ++k) ok = ok && (byte(k) & 0xc0) == 0x80;
      // No overlong forms, no surrogates, nothing beyond U+10FFFF.
      if (ok && length == 2) ok = c >= 0xc2;
      if (ok && length == 3) ok = !(c == 0xe0 && byte(1) < 0xa0) && !(c == 0xed && byte(1) >= 0xa0);
      if (ok && length == 4) ok = !(c == 0xf0 && byte(1) < 0x90) && !(c == 0xf4 && byte(1) >= 0x90) && c <= 0xf4;
      if (!ok) length = 0;
    } else if (length > 1) {
      length = 0;
    }
    if (length == 0) {
      char escaped[8];
      std::snprintf(escaped, sizeof(escaped), "\\x%02x", c);
      shown += escaped;
      ++i;
    } else {
      shown.append(text, i, length);
      i += length;
    }
  }
  return shown;
}

}  // namespace delta
