// Options of the `relight` stage: rendering the recovered model (mesh and
// per-vertex reflectance from `inverse`) under recovered, held-out, file,
// directional and point lights, from the input cameras and from new ones.
#pragma once

#include <string>
#include <vector>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kRelightStage{
    "relight", "Render the recovered model under recovered, held-out, file, directional and point lights", 10,
    /*shardable=*/true};

struct RelightOptions {
  // What to render.
  bool rerender = true;         // every input photo's camera under that photo's recovered environment map
  int rerender_max_size = 512;  // longer side of re-renderings (smaller photos keep their size); 0: photo size
  bool zero_unseen_light = true;  // recovered maps: texels no object point can see are set to 0 (less noise)
  bool heldout = true;  // ground-truth held-out views under held-out maps (when <ingest>/ground_truth/relight exists)
  std::vector<std::string> envmaps = {"/usr/share/blender/datafiles/studiolights/world/city.exr",
                                      "/usr/share/blender/datafiles/studiolights/world/sunset.exr",
                                      "/usr/share/blender/datafiles/studiolights/world/studio.exr"};  // new lights
  bool directional_light = true;                 // also a sun-like directional light (plus a dim uniform sky)
  double directional_elevation_deg = 40;         // elevation of the directional light above the horizon
  double directional_azimuth_deg = 45;           // its azimuth relative to the first new view's, towards +Y
  bool point_light = true;                       // also a point light beside the camera (plus a dim uniform sky)
  double ambient_fraction = 0.1;                 // uniform sky radiance of the delta-light renders, times E/pi
  int views = 2;                                 // new orbit cameras for the new lights and the albedo/material maps
  double view_elevation_deg = 25;                // elevation of the orbit cameras above the object's centre
  double view_azimuth_deg = 30;                  // azimuth of the first orbit camera (world, from +X towards +Y)
  int image_size = 256;                          // side of the square new-view and albedo images
  double fov_deg = 35;                           // horizontal field of view of the orbit cameras
  double fill = 0.8;                             // share of the image side the object's bounding sphere spans
  int turntable_frames = 24;                     // frames of the turntable (one orbit); 0: none
  int turntable_size = 192;                      // side of the square turntable frames
  double turntable_fps = 12;                     // frames per second of the animation
  std::string turntable_light = "first_envmap";  // first_envmap (first of envmaps) or recovered (first photo's)

  // Rendering and display.
  std::string renderer = "transport";  // transport (the model's precomputed transport, noise-free) or monte_carlo
  int pixel_samples_per_axis = 2;  // antialiasing: k x k camera rays per pixel
  int light_samples = 8;           // environment importance samples per shading point
  int brdf_samples = 8;            // BRDF importance samples per shading point
  int scored_samples = 32;         // at least this many environment and BRDF samples in the renders evaluate scores
  bool background = true;          // new views show the environment behind the object
  double occluder_albedo = 0.35;   // grey Lambertian albedo of <mesh>/occluders.ply (unless inverse recovered one)
  double tonemap_percentile = 99;  // PNG exposure maps this percentile of object luminance to white
  int seed = 1;                    // Monte Carlo streams; images are a deterministic function of it

  void Declare(OptionTable* t) {
    t->Add("rerender", &rerender,
           "Render every input photo's camera under that photo's recovered environment map (for evaluate/report).");
    t->Add("rerender_max_size", &rerender_max_size,
           "Longer side of the re-renderings in pixels (photos larger than this are rendered scaled down); 0: the "
           "photo's size.")
        .Min(0)
        .Advanced();
    t->Add("zero_unseen_light", &zero_unseen_light,
           "Recovered maps: set the texels no object point can receive light from (blocked in every sampled "
           "direction, e.g. below a ground plane; the inverse stage has no data on them) to 0. Object pixels keep "
           "their expected value; the renderer stops wasting light samples on them.")
        .Advanced();
    t->Add("heldout", &heldout,
           "Render the ground truth's held-out views under its held-out environment maps (when "
           "<ingest>/ground_truth/relight exists).");
    t->Add("envmaps", &envmaps,
           "Lat-long HDR maps (.exr/.hdr) to relight the model with, from the new orbit cameras; empty: none.")
        .InputFile();
    t->Add("directional_light", &directional_light,
           "Also render under a directional (sun-like) light plus a dim uniform sky (ambient_fraction).");
    t->Add("directional_elevation_deg", &directional_elevation_deg, "Elevation of the directional light [deg].")
        .Range(-90, 90)
        .Advanced()
        .OnlyWhen("directional_light", {"true"});
    t->Add("directional_azimuth_deg", &directional_azimuth_deg,
           "Azimuth of the directional light relative to the first orbit camera's azimuth [deg].")
        .Range(-360, 360)
        .Advanced()
        .OnlyWhen("directional_light", {"true"});
    t->Add("point_light", &point_light,
           "Also render under a point light above and beside each camera plus a dim uniform sky.");
    t->Add("ambient_fraction", &ambient_fraction,
           "Radiance of the uniform sky added to directional/point renders, as a fraction of E/pi (E: the delta "
           "light's irradiance at the object's centre); 0: black shadows.")
        .Range(0, 10)
        .Advanced();
    t->Add("views", &views, "Orbit cameras for the new lights and the albedo/material maps; 0: none.").Range(0, 64);
    t->Add("view_elevation_deg", &view_elevation_deg, "Elevation of the orbit cameras above the object [deg].")
        .Range(-80, 80)
        .Advanced();
    t->Add("view_azimuth_deg", &view_azimuth_deg,
           "Azimuth of the first orbit camera (world, from +X towards +Y) [deg]; the others are evenly spaced.")
        .Range(-360, 360)
        .Advanced();
    t->Add("image_size", &image_size, "Side of the square new-view and albedo/material images [px].").Range(16, 4096);
    t->Add("fov_deg", &fov_deg, "Horizontal field of view of the orbit cameras [deg].").Range(5, 120).Advanced();
    t->Add("fill", &fill, "Share of the image side the object's bounding sphere spans in orbit views.")
        .Range(0.1, 1.0)
        .Advanced();
    t->Add("turntable_frames", &turntable_frames, "Frames of the turntable animation (one orbit); 0: none.")
        .Range(0, 720);
    t->Add("turntable_size", &turntable_size, "Side of the square turntable frames [px].").Range(16, 2048).Advanced();
    t->Add("turntable_fps", &turntable_fps, "Frames per second of the turntable GIF.").Range(1, 60).Advanced();
    t->Add("turntable_light", &turntable_light,
           "Light of the turntable: first_envmap (the first of relight.envmaps, else the first photo's recovered "
           "map) or recovered (the first photo's recovered map).")
        .Choices({"first_envmap", "recovered"})
        .Advanced();
    t->Add("renderer", &renderer,
           "transport: the inverse stage's own forward model at the recovered maps' resolution (a map's "
           "sun traced sharp): noise-free and fast. monte_carlo: the path-traced reference, for other "
           "sharp light (several lamps) or meshes coarser than the pixels.")
        .Choices({"transport", "monte_carlo"});
    t->Add("pixel_samples_per_axis", &pixel_samples_per_axis,
           "Antialiasing: a k x k grid of camera rays per pixel (jittered with monte_carlo).")
        .Range(1, 16)
        .Advanced();
    t->Add("light_samples", &light_samples, "monte_carlo: environment importance samples per shading point.")
        .Range(0, 1024)
        .Advanced();
    t->Add("brdf_samples", &brdf_samples, "monte_carlo: BRDF importance samples per shading point (MIS).")
        .Range(0, 1024)
        .Advanced();
    t->Add("scored_samples", &scored_samples,
           "monte_carlo: the renders evaluate scores (re-renderings of the photos, held-out views) use at least "
           "this many environment and BRDF samples per shading point, so that noise does not cap their scores.")
        .Range(1, 1024)
        .Advanced();
    t->Add("background", &background, "New views show the environment map behind the object (else black).");
    t->Add("occluder_albedo", &occluder_albedo,
           "Grey Lambertian albedo given to <mesh>/occluders.ply (ground, blockers), whose reflectance is not "
           "recovered unless the inverse stage solved with inverse.interreflection: mesh_and_occluders (then its "
           "recovered albedo is used). Otherwise they matter for the shadows they cast.")
        .Range(0, 1)
        .Advanced();
    t->Add("tonemap_percentile", &tonemap_percentile,
           "PNG exposure: this percentile of the object pixels' luminance maps to white, then the sRGB curve.")
        .Range(50, 100)
        .Advanced();
    t->Add("seed", &seed, "monte_carlo: seed of the sample streams.").Advanced();
  }
  void Check() const {
    if (light_samples + brdf_samples < 1) {
      RELIGHT_USER_ERROR() << "relight.light_samples + relight.brdf_samples must be at least 1";
    }
  }
};

}  // namespace relight
