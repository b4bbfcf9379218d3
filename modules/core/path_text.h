// The one rule for turning bytes that may not be text (POSIX file names are
// any bytes but '/' and NUL; a Latin-1 `Sacr\xe9.jpg` is common on old
// archives) into text for logs, messages and JSON, which must be UTF-8.
//
// Valid UTF-8 passes through unchanged; every byte that is not part of a
// well-formed UTF-8 sequence (RFC 3629: no overlong forms, no surrogates,
// nothing above U+10FFFF) becomes the four characters `\xHH` (upper-case hex),
// as Python's "backslashreplace" does. Written by hand: neither nlohmann/json
// (which only replaces by U+FFFD, losing which byte it was) nor spdlog/fmt
// offers a reversible-looking escape.
#pragma once

#include <string>
#include <string_view>

namespace relight {

// `bytes` as valid UTF-8 text: invalid bytes become `\xHH`.
std::string PathText(std::string_view bytes);
// True when `bytes` is well-formed UTF-8 (then PathText returns it unchanged).
bool IsValidUtf8(std::string_view bytes);

}  // namespace relight
