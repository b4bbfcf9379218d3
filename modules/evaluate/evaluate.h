// The `evaluate` stage: how good is the recovered model? Every number is
// defined in docs/METRICS.md; all image and environment-map comparisons are
// scale-invariant (one least-squares factor per colour channel), because the
// inverse problem fixes light and reflectance only up to such scales.
//
// Always (when the stages ran): re-rendering error of the input photos
// (relight's re-renderings against the linear photos, over pixels of observed
// vertices), per-stage seconds. With ground truth (<ingest>/ground_truth):
// relighting error of held-out views under held-out maps, environment-map
// error and brightest-direction error, albedo PSNR, camera errors (when the
// sfm stage estimated cameras), mesh errors (when the mesh was reconstructed),
// DiLiGenT light metrics (lights.json). Without ground-truth light:
// leave-one-photo-out scores (evaluate/leave_one_out.h).
//
// Output folder: metrics.json (numbers only; a metric that cannot be computed
// is null with its reason under "not_available"), figures.json (the PNGs
// below, for the report), figures/{rerender,heldout,envmaps,albedo,loo}/*.png.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "core/json.h"
#include "evaluate/evaluate_options.h"

namespace relight {

// Upstream folders (empty when the stage did not run).
struct EvaluateInputs {
  std::string ingest_dir, sfm_dir, mesh_dir, linearize_dir, observe_dir, visibility_dir, inverse_dir, relight_dir;
};

struct EvaluateSummary {
  OrderedJson metrics;  // what metrics.json holds
  OrderedJson figures;  // what figures.json holds
  double seconds = 0;
  // One paragraph for the log: the headline numbers.
  std::string BriefReport() const;
};

// The headline keys of metrics.json (issue 7), in order.
const std::vector<std::string>& HeadlineMetricKeys();

// Runs the stage into `output_dir` (which exists).
EvaluateSummary RunEvaluate(const EvaluateOptions& options, const EvaluateInputs& inputs,
                            const std::string& output_dir);

// Per-stage wall-clock seconds of the cached stage folders in `inputs` and of the stages upstream of them
// (followed through each folder's status.json "upstream" keys to <workspace>/cache/<stage>/<key>).
// Folders without status.json (a stage run by hand) are left out.
OrderedJson CollectStageSeconds(const std::map<std::string, std::string>& inputs);

}  // namespace relight
