#include "keyfleet/common/printable_text.hpp"

#include <cstdio>

namespace keyfleet {

std::string printable_text(const std::string& raw, std::size_t max_bytes) {
  std::string out;
  for (const char c : raw.substr(0, max_bytes)) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte < 0x7f && c != '\\') {
      out += c;
    } else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", byte);
      out += hex;
    }
  }
  return out;
}

}  // namespace keyfleet
