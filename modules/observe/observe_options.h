// Options of the `observe` stage: per photo and vertex, the vertex's linear
// colour, local view direction and a confidence.
#pragma once

#include <string>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kObserveStage{
    "observe", "Per photo and vertex: linear colour, local view direction and confidence (Embree visibility)", 8,
    /*shardable=*/true};

struct ObserveOptions {
  double grazing_min_deg = 80.0;      // View angles beyond this (from the normal) get confidence 0.
  double grazing_full_deg = 60.0;     // View angles below this get full confidence; linear ramp in between.
  double depth_tolerance = 0.01;      // Relative depth difference up to which a vertex counts as visible.
  double edge_margin_px = 3.0;        // Confidence ramps from 0 to 1 over this distance from silhouettes/depth edges.
  double depth_edge_jump = 0.05;      // Relative depth jump between neighbouring pixels that marks a depth edge.
  double min_confidence = 0.05;       // Observations below this confidence are dropped.
  double footprint_scale = 1.0;       // Sampling footprint radius relative to the vertex's projected radius.
  double border_margin_px = 2.0;      // Projections closer than this to the image border are dropped.
  double max_distrusted_share = 0.25;  // Footprints with a larger share of distrusted pixels give no mean.
  std::string clipped_footprints = "lower_bound";  // What such footprints give: lower_bound or drop.
  std::string bound_channels = "clipped";  // Which channels of a lower bound are bounds: clipped or all.

  void Declare(OptionTable* t) {
    t->Add("grazing_min_deg", &grazing_min_deg,
           "View angle from the normal (degrees) at and beyond which an observation gets confidence 0.")
        .Range(1, 90);
    t->Add("grazing_full_deg", &grazing_full_deg,
           "View angle (degrees) below which the angle does not lower confidence; linear ramp up to grazing_min_deg.")
        .Range(0, 89);
    t->Add("depth_tolerance", &depth_tolerance,
           "Relative difference between a vertex's depth and the depth map up to which it counts as visible.")
        .Range(1e-4, 0.2)
        .Advanced();
    t->Add("edge_margin_px", &edge_margin_px,
           "Confidence rises from 0 at silhouettes and depth edges to 1 at this distance (pixels).")
        .Range(0, 50)
        .Advanced();
    t->Add("depth_edge_jump", &depth_edge_jump,
           "Relative depth jump between neighbouring pixels that marks a depth edge.")
        .Range(1e-3, 1)
        .Advanced();
    t->Add("min_confidence", &min_confidence, "Observations with lower confidence are dropped.").Range(0, 1);
    t->Add("footprint_scale", &footprint_scale,
           "Colour sampling radius relative to the vertex's projected radius (its share of the surface).")
        .Range(0.25, 4);
    t->Add("border_margin_px", &border_margin_px, "Projections closer than this to the image border are dropped.")
        .Range(0, 100)
        .Advanced();
    t->Add("max_distrusted_share", &max_distrusted_share,
           "A footprint with a larger share of distrusted pixels (linearize: clipped or next to a "
           "clipped pixel) gives no ordinary mean, which would be biased, but what clipped_footprints "
           "says; below it, confidence drops by the share. Lower it when many highlights clip "
           "(docs/TUNING.md).")
        .Range(0, 1);
    t->Add("clipped_footprints", &clipped_footprints,
           "What a footprint over max_distrusted_share gives. lower_bound: the mean over all its pixels, "
           "flagged as a lower bound of the true radiance, which the inverse stage enforces only while "
           "its prediction falls below, so clipped highlights still say the surface is at least this "
           "bright; drop: nothing (the earlier behaviour, kept to compare against).")
        .Choices({"lower_bound", "drop"})
        .Experimental();
    t->Add("bound_channels", &bound_channels,
           "Which channels of a lower bound are bounds. clipped: only those with an over-exposed pixel "
           "in the footprint; the others are ordinary measurements of the same mean. all: every channel "
           "(the earlier behaviour, kept to compare against).")
        .Choices({"clipped", "all"})
        .Experimental()
        .OnlyWhen("clipped_footprints", {"lower_bound"});
  }
  void Check() const {
    if (grazing_full_deg >= grazing_min_deg) {
      RELIGHT_USER_ERROR() << "observe.grazing_full_deg (" << grazing_full_deg
                           << ") must be smaller than observe.grazing_min_deg (" << grazing_min_deg << ")";
    }
  }
};

}  // namespace relight
