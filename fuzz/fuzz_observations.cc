// observations.bin (docs/FORMATS.md, versions 1-4). Only UserError may come out.
#include "core/error.h"
#include "fuzz_common.h"
#include "observe/observations.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace relight;
  const std::string path =
      fuzz::WriteScratch("observations.bin", std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    ReadObservations(path);
  } catch (const UserError&) {
  }
  return 0;
}
