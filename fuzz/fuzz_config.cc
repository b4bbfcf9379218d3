// The YAML config layer: parsing, sections, `base:` chains (a base file that
// is this same input), every stage's options and their validation, as
// `pipeline` resolves a config. Only UserError may come out.
#include "core/config.h"
#include "core/error.h"
#include "fuzz_common.h"
#include "pipeline/stage_graph.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace relight;
  const std::string path = fuzz::WriteScratch("config.yaml", std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    ConfigDocument doc = ConfigDocument::Load(path);
    const pipeline::ResolvedConfig config(doc, pipeline::AllStages());
    (void)config;
  } catch (const UserError&) {
  }
  return 0;
}
