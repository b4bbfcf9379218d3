#include "core/json.h"

#include "core/error.h"
#include "core/fs.h"
#include "core/path_text.h"

namespace relight {
namespace {

// A copy of `value` whose strings and keys follow the path-to-text rule (PathText).
template <typename J>
J ToValidText(const J& value) {
  if (value.is_string()) return J(PathText(value.template get_ref<const std::string&>()));
  if (value.is_array()) {
    J out = J::array();
    for (const auto& item : value) out.push_back(ToValidText(item));
    return out;
  }
  if (value.is_object()) {
    J out = J::object();
    for (auto it = value.begin(); it != value.end(); ++it) out[PathText(it.key())] = ToValidText(it.value());
    return out;
  }
  return value;
}

// Pretty-printed JSON; strings holding bytes that are not UTF-8 (file names)
// are written by the path-to-text rule instead of failing the write.
template <typename J>
std::string Dump(const J& value) {
  try {
    return value.dump(2) + "\n";
  } catch (const typename J::type_error&) {
    return ToValidText(value).dump(2) + "\n";
  }
}

}  // namespace

Json ReadJsonFile(const std::string& path) {
  const std::string text = ReadFileToString(path);
  try {
    return Json::parse(text);
  } catch (const Json::parse_error& e) {
    RELIGHT_USER_ERROR() << "'" << path << "' is not valid JSON (" << e.what()
                         << "); it may be damaged: delete it and rerun the stage that wrote it";
  }
}

void WriteJsonAtomic(const std::string& path, const Json& value) { WriteFileAtomic(path, Dump(value)); }

void WriteJsonAtomic(const std::string& path, const OrderedJson& value) { WriteFileAtomic(path, Dump(value)); }

}  // namespace relight
