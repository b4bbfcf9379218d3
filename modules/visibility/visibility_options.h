// Options of the `visibility` stage: per-vertex hemispherical visibility as sparse Haar wavelets.
#pragma once

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kVisibilityStage{
    "visibility", "Embree visibility of every vertex's hemisphere, stored as sparse Haar wavelets", 1};

struct VisibilityOptions {
  int resolution = 32;          // Side of the hemi-octahedral visibility map (power of two).
  int supersampling = 2;        // Rays per texel side (supersampling^2 rays per texel).
  double keep_energy = 0.9999;  // Keep the fewest Haar coefficients holding this share of each map's energy.
  double origin_offset = 1e-3;  // Ray origin offset along the normal, relative to the vertex's mean edge length.
  int chunk_vertices = 20000;   // Vertices per resumable chunk.

  void Declare(OptionTable* t) {
    t->Add("resolution", &resolution, "Side of the hemi-octahedral visibility map per vertex: 16, 32 or 64.")
        .Range(4, 256);
    t->Add("supersampling", &supersampling, "Rays per texel side; each texel averages supersampling² rays.")
        .Range(1, 8);
    t->Add("keep_energy", &keep_energy,
           "Keep the fewest Haar coefficients holding this share of each visibility map's energy "
           "(1 keeps all; relative L2 error = sqrt(1 - keep_energy)).")
        .Range(0.5, 1.0);
    t->Add("origin_offset", &origin_offset,
           "Ray origins move this far along the normal, relative to the vertex's mean incident edge length "
           "(plus a scene-scale float epsilon), to avoid self-intersection acne.")
        .Range(0, 0.5)
        .Advanced();
    t->Add("chunk_vertices", &chunk_vertices, "Vertices per resumable chunk (a killed run resumes per chunk).")
        .Min(100)
        .NotInKey()
        .Advanced();
  }
  void Check() const {
    if (resolution & (resolution - 1)) {
      RELIGHT_USER_ERROR() << "visibility.resolution = " << resolution << " must be a power of two (16, 32, 64)";
    }
  }
};

}  // namespace relight
