// mvs_evaluate: scores an mvs stage output against a ground-truth folder (see evaluate/mvs_evaluation.h).
//
//   mvs_evaluate [--maps=TYPE] [--pixel-centres] MVS_OUTPUT_DIR GROUND_TRUTH_DIR [JSON_OUT]
//
// e.g. mvs_evaluate <ws>/cache/mvs/<key> <ws>/cache/ingest/<key>/ground_truth
// --maps=geometric_unfiltered (or photometric) scores the maps before filtering instead of the final ones;
// --pixel-centres compares at our pixel centres instead of along the true point's ray (the first scoring
// in docs/RESULTS.md@15cf301).
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/json.h"
#include "core/log.h"
#include "evaluate/mvs_evaluation.h"

int main(int argc, char** argv) {
  using namespace relight;
  MvsEvaluationOptions options;
  std::vector<std::string> args;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.rfind("--maps=", 0) == 0) {
      options.map_type = arg.substr(7);
    } else if (arg == "--pixel-centres") {
      options.intersect_planes = false;
    } else {
      args.push_back(arg);
    }
  }
  if (args.size() < 2 || args.size() > 3) {
    std::fprintf(stderr, "usage: %s [--maps=TYPE] [--pixel-centres] MVS_OUTPUT_DIR GROUND_TRUTH_DIR [JSON_OUT]\n",
                 argv[0]);
    return 2;
  }
  InitLogging("mvs_evaluate", "", LogLevel::kWarning);
  try {
    const MvsEvaluation e = EvaluateMvs(args[0], args[1], options);
    std::printf("%s\n", e.BriefReport().c_str());
    std::printf(
        "completeness: fraction of the object's pixels within 1%% of the view's true depth range over the "
        "object (obj) / over the scene (scene)\n");
    std::printf("%-24s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s\n", "view", "pixels", "range", "scene", "obj", "scene",
                "missing", "inside", "edge", "med|err|", "med err");
    for (const auto& v : e.views) {
      std::printf("%-24s %8zu %8.3f %8.3f %8.3f %8.3f %8.3f %8.3f %8.3f %8.4f %8.4f\n", v.name.c_str(), v.object_pixels,
                  v.object_depth_range, v.scene_depth_range, v.completeness, v.completeness_scene, v.missing,
                  v.completeness_interior, v.completeness_edge, v.median_error, v.median_signed_error);
    }
    if (args.size() == 3) WriteJsonAtomic(args[2], e.ToJson());
    return 0;
  } catch (const UserError& e) {
    std::fprintf(stderr, "mvs_evaluate: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mvs_evaluate: internal error: %s\n", e.what());
    return 3;
  }
}
