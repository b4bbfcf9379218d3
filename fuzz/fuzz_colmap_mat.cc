// COLMAP's depth/normal map format ("W&H&C&" + float32 planes), as the mvs
// stage and its evaluation read it. Only UserError may come out.
#include "core/error.h"
#include "fuzz_common.h"
#include "mvs/colmap_mat.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace relight;
  fuzz::ScratchDir();  // logging off
  try {
    DecodeColmapMat(std::string(reinterpret_cast<const char*>(data), size), "fuzz.bin");
  } catch (const UserError&) {
  }
  return 0;
}
