// JSON (nlohmann/json) with the project's file conventions.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace relight {

using Json = nlohmann::json;
// Keys in insertion order, for human-facing summaries.
using OrderedJson = nlohmann::ordered_json;

// Reads a JSON file; throws UserError naming the file on a missing file or a parse error.
Json ReadJsonFile(const std::string& path);
// Writes pretty-printed JSON atomically. Strings that are not UTF-8 (file names)
// are written by the path-to-text rule (core/path_text.h) instead of throwing.
void WriteJsonAtomic(const std::string& path, const Json& value);
void WriteJsonAtomic(const std::string& path, const OrderedJson& value);

}  // namespace relight
