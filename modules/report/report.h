// The `report` stage: one self-contained HTML page (index.html) that shows
// what the pipeline recovered and how good it is, for synthetic scenes and
// real collections alike:
//   the metrics table (metrics.json of `evaluate`, copied beside the page);
//   the input photos beside their re-renderings and error heat maps;
//   the recovered environment maps (octahedral and lat-long) beside the true ones;
//   the albedo and dominant material on the mesh (beside the true albedo), with a legend;
//   held-out views relit under held-out maps; the model under new lights; a turntable;
//   links to the glTF export (model.glb, scene.json; copied with its maps into export/);
//   convergence curves of the inverse solve, leave-one-photo-out scores, stage timings.
// Every image the page shows is copied into the report folder (images/), every
// chart is an SVG drawn by gnuplot from a CSV beside it (charts/, report/charts.h);
// all paths in the page are relative and nothing is fetched from the network.
// An inline script checks on load that every image decoded and records the
// result in the page (element #selfcheck, attribute data-status = ok | fail),
// which the headless-browser test reads.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "report/report_options.h"

namespace relight {

struct ReportSummary {
  int images = 0;                  // images copied into the report folder and shown
  int charts = 0;                  // charts drawn
  std::vector<std::string> notes;  // sections left out and why; chart failures
  std::string page;                // index.html
  double seconds = 0;

  // One line for the log.
  std::string BriefReport() const;
};

// The upstream stage folders the report is built from; any may be empty (its sections are left out).
struct ReportInputs {
  std::string ingest_dir, sfm_dir, mesh_dir, linearize_dir, observe_dir, inverse_dir, relight_dir, evaluate_dir;

  // Stage name -> folder, the non-empty ones.
  std::map<std::string, std::string> ByStage() const;
};

// Writes index.html, metrics.json (when `evaluate` ran), images/ and charts/ into `output_dir`.
ReportSummary RunReport(const ReportOptions& options, const ReportInputs& inputs, const std::string& output_dir);

}  // namespace relight
