// A sun split out of an environment map as a directional light.
//
// A renderer that filters the light to a coarse map (relight/transport_render.h: the recovered maps'
// 32² octahedral texels, about 6° wide) spreads a real sun (0.5° wide) over a texel: its shadows and
// highlights blur and shadowed surfaces catch light the sun does not send there. Taking the sun out as
// a delta light, traced with one shadow ray per shading point, keeps them sharp; the rest of the map
// (sky, aureole, ground) is filtered as before. The same split is what game engines and Blender's
// "sun from HDRI" add-ons do by hand.
//
// The sun is the brightest stored pixel of the map when its light is compact and dominant:
//  - the ring around it (angular distance in [R, 2R], R = `max_radius_rad`) has median luminance at
//    most 1/kSunPeakOverRing of the peak's: the lobe fits within R;
//  - the excess over the ring's level inside R holds at least kSunMinShare of the map's integral.
// The excess (per channel, radiance above the ring's median colour, times each pixel's solid angle)
// becomes the directional light's irradiance, its direction the excess-weighted mean direction; the
// residual map holds the ring's colour inside R. Irradiance is conserved: residual + sun integrate to
// the map's integral.
#pragma once

#include "render/lighting.h"
#include "sphere/envmap.h"

namespace relight {

inline constexpr double kSunPeakOverRing = 20;
inline constexpr double kSunMinShare = 0.05;

struct SunSplit {
  bool found = false;
  DirectionalLight sun;  // world direction and irradiance (with the map's rotation and intensity)
  EnvMap residual;       // the map without the sun (same layout, rotation and intensity); empty if !found
  double share = 0;      // the sun's share of the map's integral (luminance)
};

// Lat-long maps only (octahedral maps at the renderer's own resolution are left whole: not found).
SunSplit SplitSun(const EnvMap& env, double max_radius_rad);

}  // namespace relight
