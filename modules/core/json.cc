#include "core/json.h"

#include "core/error.h"
#include "core/fs.h"

namespace relight {

Json ReadJsonFile(const std::string& path) {
  const std::string text = ReadFileToString(path);
  try {
    return Json::parse(text);
  } catch (const Json::parse_error& e) {
    RELIGHT_USER_ERROR() << "'" << path << "' is not valid JSON (" << e.what()
                         << "); it may be damaged: delete it and rerun the stage that wrote it";
  }
}

void WriteJsonAtomic(const std::string& path, const Json& value) { WriteFileAtomic(path, value.dump(2) + "\n"); }

void WriteJsonAtomic(const std::string& path, const OrderedJson& value) {
  WriteFileAtomic(path, value.dump(2) + "\n");
}

}  // namespace relight
