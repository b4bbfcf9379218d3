// COLMAP text models: cameras.txt, images.txt, points3D.txt from one input
// split at "\n%%\n" lines. Only UserError may come out.
#include "core/error.h"
#include "fuzz_common.h"
#include "geometry/reconstruction.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace relight;
  const auto parts = fuzz::SplitParts(std::string_view(reinterpret_cast<const char*>(data), size), 3);
  const char* names[] = {"cameras.txt", "images.txt", "points3D.txt"};
  for (size_t i = 0; i < 3; ++i) fuzz::WriteScratch(names[i], i < parts.size() ? parts[i] : std::string_view());
  try {
    Reconstruction::ReadText(fuzz::ScratchDir());
  } catch (const UserError&) {
  }
  return 0;
}
