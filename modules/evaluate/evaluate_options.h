// Options of the `evaluate` stage: how the recovered model is scored against
// the photos and, when it exists, the ground truth (definitions: docs/METRICS.md).
#pragma once

#include <string>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kEvaluateStage{
    "evaluate", "Metrics against ground truth (or leave-one-photo-out without it), error heat maps", 7};

struct EvaluateOptions {
  // Image metrics.
  double peak_percentile = 99;  // HDR-PSNR peak: this percentile of the reference inside the mask
  bool clip_to_peak = true;     // clip reference and scaled estimate to [0, peak] before the error
  int mask_erosion_px = 1;      // erode comparison masks by this many pixels (antialiased borders)
  double min_confidence = 0.5;  // re-rendering masks keep photo pixels whose linearize confidence is at least this
  double heatmap_max = 0.2;     // error heat maps: this error (fraction of the peak) is the top colour

  // Environment maps.
  std::string envmap_region = "auto";  // auto, sphere or upper (hemisphere above the ground-truth horizon)

  // Geometry.
  int mesh_samples = 20000;  // surface samples per mesh for the Chamfer distance

  // Leave-one-photo-out.
  std::string leave_one_out = "auto";  // auto (only without ground-truth light), always or never
  int loo_max_photos = 4;              // photos scored (evenly spread over the collection); 0: all
  int loo_max_iterations = 2;          // outer iterations of each fold from its group's reflectance; 0: as inverse

  void Declare(OptionTable* t) {
    t->Add("peak_percentile", &peak_percentile,
           "HDR-PSNR peak: this percentile of the reference's values inside the mask (100: the maximum).")
        .Range(50, 100);
    t->Add("clip_to_peak", &clip_to_peak,
           "Clip reference and scaled estimate to [0, peak] before computing the error (a few highlights do not "
           "dominate).")
        .Advanced();
    t->Add("mask_erosion_px", &mask_erosion_px,
           "Erode every comparison mask by this many pixels (object borders mix object and background).")
        .Range(0, 16);
    t->Add("min_confidence", &min_confidence,
           "Re-rendering masks keep photo pixels whose linearize confidence is at least this (clipped pixels have 0).")
        .Range(0, 1)
        .Advanced();
    t->Add("heatmap_max", &heatmap_max,
           "Error heat maps: this per-pixel error, as a fraction of the peak, is the top of the colour scale.")
        .Range(1e-4, 10)
        .Advanced();
    t->Add("envmap_region", &envmap_region,
           "Where environment maps are compared: sphere, upper (above the ground truth's horizon), or auto (upper "
           "when the ground truth has occluders.ply, i.e. a ground that hides the lower hemisphere, else sphere).")
        .Choices({"auto", "sphere", "upper"});
    t->Add("mesh_samples", &mesh_samples, "Area-uniform surface samples per mesh for the Chamfer distance.")
        .Range(100, 10000000)
        .Advanced();
    t->Add("leave_one_out", &leave_one_out,
           "Leave-one-photo-out scores (a reflectance solve without each scored photo; docs/METRICS.md): auto (only "
           "when the ground truth knows no light: no relight references, lighting.json or lights.json), always, or "
           "never.")
        .Choices({"auto", "always", "never"});
    t->Add("loo_max_photos", &loo_max_photos,
           "Photos scored by leave-one-photo-out, evenly spread over the collection; 0: all. Each costs one short "
           "reflectance solve: raise it for a score over more of the collection.")
        .Min(0)
        .OnlyWhen("leave_one_out", {"auto", "always"});
    t->Add("loo_max_iterations", &loo_max_iterations,
           "Outer iterations of each leave-one-out solve started from its group's reflectance (solved without the "
           "group's photos); 0: inverse.max_iterations. Raise it when the folds' iterations still lower the error.")
        .Min(0)
        .Advanced()
        .OnlyWhen("leave_one_out", {"auto", "always"});
    t->Retired("loo_light_samples",
               "leave-one-out renders use the relight stage's renderer and samples (relight.renderer); delete the key");
    t->Retired("loo_brdf_samples",
               "leave-one-out renders use the relight stage's renderer and samples (relight.renderer); delete the key");
  }
  void Check() const {}
};

}  // namespace relight
