// Rendering the recovered model from any COLMAP cameras under any environment map: the library behind
// `pipeline render CONFIG --cameras MODEL_DIR --envmap FILE ...` (pipeline/pipeline_main.cc) and the
// `render_cameras` executable it runs.
//
// Environment map conventions (docs/FORMATS.md, "Environment map conventions", with a figure): a lat-long
// map's column u and row v name a direction differently in each tool; rows agree (row 0 is the zenith
// in all three), columns do not. With φ the project's azimuth (from +X towards +Y, world +Z up):
//   relight  u = φ / 2π                          (docs/FORMATS.md)
//   blender  u = 1/2 − φ / 2π                    (Cycles' Environment Texture, Texture Coordinate Generated,
//                                                 no Mapping: a mirror and a half turn from ours)
//   mitsuba  u = 1/4 − φ / 2π                    (Mitsuba 3 `envmap` with an identity to_world, its +Y up
//                                                 being our +Z: Mitsuba (x, y, z) = ours (x, z, −y), the
//                                                 axis change of the glTF export)
// Octahedral maps (square files) exist in this project's convention only.
#pragma once

#include <string>
#include <vector>

#include "image/image.h"
#include "relight/views.h"
#include "sphere/envmap.h"

namespace relight {

enum class EnvmapConvention { kRelight, kBlender, kMitsuba };
// "relight", "blender", "mitsuba"; throws UserError naming the accepted values otherwise.
EnvmapConvention ParseEnvmapConvention(const std::string& name);
std::string EnvmapConventionName(EnvmapConvention convention);

// The lat-long image (W = 2H) `latlong` of convention `from` resampled to the project's convention: column
// positions map exactly (a permutation of columns when W is a multiple of 4), otherwise linearly between
// the two nearest columns.
Image LatLongToProjectConvention(const Image& latlong, EnvmapConvention from);

// Reads a map file (.exr/.hdr; lat-long 2:1 of any convention, or octahedral square of the project's),
// converts it to the project's convention, turns it by `rotate_deg` about +Z (a light at azimuth φ moves to
// φ + rotate_deg) and scales it by `strength`. Throws UserError naming the file when it is unusable.
EnvMap LoadEnvmapInConvention(const std::string& path, EnvmapConvention convention, double rotate_deg = 0,
                              double strength = 1);

struct RenderCamerasRequest {
  std::string inverse_dir;     // reflectance.ply, materials.json, lighting.json of the inverse stage
  std::string mesh_dir;        // occluders.ply of the mesh stage (optional)
  std::string visibility_dir;  // visibility.bin (renderer "transport")
  std::string cameras_dir;     // a COLMAP model (cameras, images; .txt or .bin) in the model's frame
  std::string envmap;          // the light: a map file
  EnvmapConvention convention = EnvmapConvention::kRelight;
  double rotate_deg = 0;       // turn of the light about +Z [deg], from +X towards +Y
  double strength = 1;         // scale of the light's radiance
  std::string output_dir;      // <image stem>.exr / .png / _mask.png, render_summary.json
  std::string renderer = "transport";  // transport or monte_carlo (relight.renderer)
  int max_size = 0;            // longer image side; larger cameras are scaled down; 0: the cameras' sizes
  int pixel_samples_per_axis = 2;
  int monte_carlo_samples = 32;  // monte_carlo: environment and BRDF samples per shading point
  bool background = true;
  double occluder_albedo = 0.35;
  double tonemap_percentile = 99;
};

struct RenderedCamera {
  std::string name, exr, png, mask;  // image name in the model; files relative to output_dir
  int width = 0, height = 0;
  double exposure = 1, seconds = 0;
};

struct RenderCamerasSummary {
  std::vector<RenderedCamera> images;
  std::string convention;
  double seconds = 0;
  std::string BriefReport() const;
};

// Renders every image of the camera model; writes each file atomically and render_summary.json.
// Throws UserError naming what is missing or unusable.
RenderCamerasSummary RenderCameras(const RenderCamerasRequest& request);

}  // namespace relight
