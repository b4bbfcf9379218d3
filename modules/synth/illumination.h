// Lighting conditions of a synthetic photo collection: environment maps from
// HDR files (rotated about +Z and scaled per condition) or the procedural
// sun-and-sky model (sphere/sky.h) with drawn sun direction and turbidity,
// turned into the exact lat-long EnvMap each photo is rendered with.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/json.h"
#include "render/rng.h"
#include "sphere/envmap.h"
#include "sphere/sky.h"
#include "synth/synthesize_options.h"

namespace relight {

// One distant lighting condition.
struct LightingCondition {
  std::string name;            // "light_03", or the held-out map's name
  std::string source = "sky";  // "file" (an env map file) or "sky" (procedural sun and sky)
  std::string file;            // source "file": the env map file as configured
  double rotation_z_deg = 0;   // source "file": rotation about +Z applied to the file's map [deg]
  double intensity = 1;        // scale of the radiance (file) or of the sky model (sky)
  SunSkyParams sky;            // source "sky": sun direction, turbidity, ground albedo, sun radius, intensity
};

// Draws `count` lighting conditions of the photos: a fraction `sky_fraction`
// from the sky model (all when `envmaps` is empty), the others cycling through
// `envmaps`, with rotation and intensity drawn per condition.
std::vector<LightingCondition> DrawPhotoLightings(const SynthesizeOptions& options, int count, Pcg32* rng);
// The held-out conditions of the relighting references: every `relight_envmaps`
// file as is, then `relight_skies` skies drawn like the photos' skies. Names are
// file stems (made unique) and "sky_<i>".
std::vector<LightingCondition> DrawHeldOutLightings(const SynthesizeOptions& options, Pcg32* rng);

// Loads env map files once and reuses them.
class EnvMapCache {
 public:
  // The file's map; throws UserError naming the file when unreadable or not lat-long.
  const EnvMap& Get(const std::string& path);

 private:
  std::map<std::string, std::shared_ptr<EnvMap>> maps_;
};

// The lat-long image (height `latlong_height`, width twice that) of a condition:
// for a file, its map rotated and scaled and resampled (texel averages); for the
// sky, the sky model rasterised at that size. It is exactly the light a photo is
// rendered with and the ground-truth map written for it.
Image RenderLightingLatLong(const LightingCondition& condition, int latlong_height, EnvMapCache* cache);

// JSON description of a condition (docs/FORMATS.md, lighting.json).
OrderedJson LightingConditionToJson(const LightingCondition& condition);

}  // namespace relight
