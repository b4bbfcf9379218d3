// mvs_evaluate: scores an mvs stage output against a ground-truth folder (see mvs/mvs_evaluation.h).
//
//   mvs_evaluate MVS_OUTPUT_DIR GROUND_TRUTH_DIR [JSON_OUT]
//
// e.g. mvs_evaluate <ws>/cache/mvs/<key> <ws>/cache/ingest/<key>/ground_truth
#include <cstdio>
#include <exception>

#include "core/error.h"
#include "core/json.h"
#include "core/log.h"
#include "mvs/mvs_evaluation.h"

int main(int argc, char** argv) {
  using namespace relight;
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: %s MVS_OUTPUT_DIR GROUND_TRUTH_DIR [JSON_OUT]\n", argv[0]);
    return 2;
  }
  InitLogging("mvs_evaluate", "", LogLevel::kWarning);
  try {
    const MvsEvaluation e = EvaluateMvs(argv[1], argv[2]);
    std::printf("%s\n", e.BriefReport().c_str());
    std::printf("%-24s %9s %12s %8s %14s\n", "view", "pixels", "within 1%", "missing", "median |err|");
    for (const auto& v : e.views) {
      std::printf("%-24s %9zu %12.3f %8.3f %14.4f\n", v.name.c_str(), v.object_pixels, v.completeness, v.missing,
                  v.median_error);
    }
    if (argc == 4) WriteJsonAtomic(argv[3], e.ToJson());
    return 0;
  } catch (const UserError& e) {
    std::fprintf(stderr, "mvs_evaluate: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mvs_evaluate: internal error: %s\n", e.what());
    return 3;
  }
}
