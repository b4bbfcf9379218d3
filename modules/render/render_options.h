// Options of the Monte Carlo renderer (render/integrator.h, render/render_view.h).
#pragma once

#include <cstdint>

namespace relight {

struct RenderOptions {
  int pixel_samples_per_axis = 2;     // antialiasing: a jittered k x k grid of camera rays per pixel
  int light_samples = 8;              // environment importance samples per shading point
  int brdf_samples = 8;               // BRDF importance samples per shading point (MIS, power heuristic)
  bool interreflection = false;       // add one bounce of indirect light (direct light where BRDF samples hit)
  bool bounce_from_occluders =
      true;  // with interreflection: occluder surfaces reflect light too (else they only block)
  int bounce_light_samples = 2;       // environment samples at a point reached by a bounce
  int bounce_brdf_samples = 1;        // BRDF samples at a point reached by a bounce
  uint64_t seed = 1;                  // output is a deterministic function of the seed, whatever the thread count
  int tile_size = 16;                 // pixels per side of one parallel work unit
  bool background = true;             // camera rays that miss every surface show the environment (else black)
  double ray_offset_relative = 1e-4;  // offset of rays leaving a surface, relative to the scene diagonal

  // Throws UserError naming the violated constraint.
  void Check() const;
};

}  // namespace relight
