// Small text helpers shared by the stages and the orchestrator.
#pragma once

#include <string>
#include <string_view>

namespace relight {

// `s` without its leading and trailing spaces, tabs and line breaks.
inline std::string TrimWhitespace(std::string_view s) {
  const size_t b = s.find_first_not_of(" \t\r\n");
  if (b == std::string_view::npos) return "";
  const size_t e = s.find_last_not_of(" \t\r\n");
  return std::string(s.substr(b, e - b + 1));
}

}  // namespace relight
