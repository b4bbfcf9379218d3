// loo_folds: leave-one-photo-out folds started from scratch against warm-started
// folds (evaluate/leave_one_out.h), on a finished workspace. For each scored
// photo it prints the RMSE of the photo's observations under its map fitted
// with the reflectance of
//   in-sample  the full solve (which saw the photo),
//   cold       a fold from scratch (what the stage ran before groups),
//   full k     a fold of k iterations started from the full solve (it saw the photo),
//   group k    a fold of k iterations started from its group's solve (which did not: the stage's way),
// with each fold's seconds (a group's shared solve is listed once per group). A fold that
// scores below the cold one towards the in-sample fit inherited what its start learnt from the photo.
//
//   loo_folds WORKSPACE [--photos 4] [--warm-iterations 1,3]
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>

#include "core/config.h"
#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/options.h"
#include "core/timer.h"
#include "evaluate/leave_one_out.h"
#include "relight/relight.h"

int main(int argc, char** argv) {
  using namespace relight;
  CLI::App app("Cold against warm-started leave-one-photo-out folds on a finished workspace", "loo_folds");
  std::string workspace;
  int photos = 4;
  std::vector<int> warm_iterations = {1, 3};
  app.add_option("WORKSPACE", workspace, "Workspace of a finished run (its stages/ links are read)")->required();
  app.add_option("--photos", photos, "Photos scored, evenly spread over the collection (0: all)");
  app.add_option("--warm-iterations", warm_iterations, "Iterations of the warm folds, one fold per entry")
      ->delimiter(',');
  CLI11_PARSE(app, argc, argv);
  try {
    InitLogging("loo_folds", "", LogLevel::kWarning);
    const std::string stages = JoinPath(workspace, "stages");
    const std::string mesh = JoinPath(stages, "mesh"), inverse = JoinPath(stages, "inverse");
    InverseProblem problem = LoadInverseProblem(mesh, JoinPath(stages, "visibility"), JoinPath(stages, "observe"));
    InverseOptions options;
    const std::string config = JoinPath(inverse, "config.yaml");
    if (std::filesystem::is_regular_file(config)) {
      OptionTable table = MakeOptionTable("inverse", &options);
      ConfigDocument::Load(config).Apply(&table);
    }
    const RecoveredModel full = LoadRecoveredModel(inverse, mesh);
    const ReflectanceState warm = ReflectanceStateOf(full.mesh, full.reflectance);
    std::printf("%-26s %10s %10s %7s", "photo", "in-sample", "cold", "s");
    for (int k : warm_iterations) std::printf("   full %-2d %7s", k, "s");
    for (int k : warm_iterations) std::printf("  group %-2d %7s", k, "s");
    std::printf("\n");
    const size_t nk = warm_iterations.size();
    std::vector<double> rmse_ratio(1 + 2 * nk, 0.0), time_ratio(2 * nk, 0.0);
    const std::vector<uint32_t> chosen = SpreadPhotos(problem.observations.num_photos, photos);
    double group_seconds = 0, cold_seconds = 0;
    for (const std::vector<uint32_t>& group : LeaveOutGroups(chosen, problem.observations.num_photos)) {
      Timer group_timer;
      const ReflectanceState group_start = group.size() > 1 ? SolveWithout(&problem, options, group) : warm;
      if (group.size() > 1) group_seconds += group_timer.Seconds();
      for (uint32_t i : group) {
        InverseProblem one;
        one.mesh = problem.mesh;
        one.footprint_scale = problem.footprint_scale;
        one.mesh_source = problem.mesh_source;
        one.visibility = problem.visibility;
        one.observations = RestrictObservations(problem.observations, {i});
        double in_sample = 0;
        FitLighting(one, options, warm, &in_sample);
        const LeaveOneOutFit cold = LeaveOneOut(&problem, options, i, 0);
        cold_seconds += cold.seconds;
        std::printf("%-26s %10.5g %10.5g %7.1f", problem.photos[i].name.c_str(), in_sample, cold.photo_rmse,
                    cold.seconds);
        rmse_ratio[0] += in_sample / cold.photo_rmse;
        for (int pass = 0; pass < 2; ++pass) {
          for (size_t k = 0; k < nk; ++k) {
            if (pass == 1 && group.size() == 1) {  // a group of one is the fold from scratch
              std::printf(" %10.5g %7.1f", cold.photo_rmse, 0.0);
              rmse_ratio[1 + nk + k] += 1;
              continue;
            }
            const LeaveOneOutFit w =
                LeaveOneOut(&problem, options, i, warm_iterations[k], pass == 0 ? &warm : &group_start);
            std::printf(" %10.5g %7.1f", w.photo_rmse, w.seconds);
            rmse_ratio[1 + pass * nk + k] += w.photo_rmse / cold.photo_rmse;
            time_ratio[pass * nk + k] += w.seconds;
          }
        }
        std::printf("\n");
        std::fflush(stdout);
      }
    }
    const double n = static_cast<double>(chosen.size());
    std::printf("mean RMSE ratio to cold: in-sample %.3f", rmse_ratio[0] / n);
    for (size_t k = 0; k < nk; ++k) std::printf("; full %d: %.3f", warm_iterations[k], rmse_ratio[1 + k] / n);
    for (size_t k = 0; k < nk; ++k) std::printf("; group %d: %.3f", warm_iterations[k], rmse_ratio[1 + nk + k] / n);
    std::printf("\nseconds for the %zu photos: cold folds %.1f", chosen.size(), cold_seconds);
    for (size_t k = 0; k < nk; ++k)
      std::printf("; group %d: %.1f (group solves %.1f + folds %.1f)", warm_iterations[k],
                  group_seconds + time_ratio[nk + k], group_seconds, time_ratio[nk + k]);
    std::printf("\n");
  } catch (const UserError& e) {
    std::fprintf(stderr, "loo_folds: %s\n", e.what());
    return 1;
  }
  return 0;
}
