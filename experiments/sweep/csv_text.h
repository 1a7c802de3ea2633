// CSV text (RFC 4180) as the sweep's tables write and read it.
#pragma once

#include <string>

namespace dsnake {

// A CSV field: quoted when it holds a comma, a quote or a line break (quotes doubled).
inline std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

}  // namespace dsnake
