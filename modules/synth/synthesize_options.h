// Options of the `synthesize` stage: a synthetic photo collection with complete
// ground truth (docs/SYNTHETIC.md explains every option, docs/FORMATS.md the
// files). Lengths are in object sizes unless stated (the object's largest
// bounding-box side is `object_size` scene units), angles in degrees.
#pragma once

#include <string>
#include <vector>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kSynthesizeStage{
    "synthesize", "Render a synthetic photo collection (object, ground, varied lighting) with complete ground truth",
    2};

struct SynthesizeOptions {
  // Object.
  std::string shape = "torus_knot";  // Built-in object: sphere, torus_knot, blob (ignored when `mesh` is set).
  std::string mesh;                  // Object mesh file (OBJ/PLY/OFF); empty: the built-in `shape`.
  std::string mesh_up = "+y";        // Axis of the mesh file that points up (+x, -x, +y, -y, +z, -z).
  double object_yaw_deg = 0;         // Rotation of the object about +Z after uprighting [deg].
  double object_size = 1.0;          // Largest bounding-box side of the object [scene units].
  int object_vertices = 40000;       // Built-in shapes get about this many vertices; files are subdivided up to it.
  int object_max_vertices = 0;       // Mesh files with more vertices are remeshed down to about this many; 0: never.
  // Reflectance.
  std::string materials;            // materials.json with basis BRDFs and materials; empty: the built-in set.
  int num_materials = 3;            // How many built-in materials to use (1..4; ignored with `materials`).
  std::string pattern = "noise";    // Weight pattern: noise, voronoi, single.
  double pattern_frequency = 5.0;   // Pattern cycles per object size (coarsest octave).
  int pattern_octaves = 4;          // Fractal octaves of the noise pattern.
  double pattern_sharpness = 40.0;  // Softmax gain of the weights: larger gives crisper material borders.
  // Ground and blockers.
  bool ground = true;                     // Add the textured ground plane z = 0.
  std::string ground_shape = "square";    // square (side ground_size) or disk (diameter ground_size).
  double ground_size = 6.0;               // Side (square) or diameter (disk) of the ground [object sizes].
  int ground_cells = 256;                 // Grid cells per side of the ground (its texture lives on vertices).
  double ground_pattern_frequency = 3.0;  // Ground pattern cycles per object size.
  std::string ground_pattern = "mosaic";  // Ground texture: mosaic (distinct colours), noise (stone), plain.
  std::string ground_materials;           // materials.json of the ground and blockers; empty: built-in stone and sand.
  int num_blockers = 0;                   // Boxes standing beside the object that cast shadows on it.
  double blocker_height = 1.0;            // Height of a blocker [object sizes].
  double blocker_width = 0.3;             // Side of a blocker's square footprint [object sizes].
  double blocker_distance = 1.0;          // Distance of a blocker's centre from the object's axis [object sizes].
  // Illumination.
  std::vector<std::string> envmaps;   // Lat-long HDR/EXR environment maps; empty: procedural sky only.
  double sky_fraction = 0.5;          // Fraction of lighting conditions from the sun-and-sky model (1 without envmaps).
  int num_lightings = 0;              // Distinct lighting conditions, assigned to photos in turn; 0: one per photo.
  std::string lighting_order = "interleaved";  // Which photos share a lighting: interleaved (p mod L) or blocks.
  double env_rotation_deg = 360;      // Env-map rotation about +Z drawn uniformly from [0, this) [deg].
  double intensity_min = 0.5;         // Light intensity scale, log-uniform in [intensity_min, intensity_max].
  double intensity_max = 2.0;         // Upper end of the intensity scale.
  double sun_elevation_min_deg = 15;  // Sun elevation above the horizon, uniform in [min, max] [deg].
  double sun_elevation_max_deg = 70;  // Upper end of the sun elevation [deg].
  double turbidity_min = 2.0;         // Preetham turbidity, uniform in [min, max] (1.7 clear .. 10 hazy).
  double turbidity_max = 6.0;         // Upper end of the turbidity.
  double sky_ground_albedo = 0.2;     // Albedo of the sky model's lower hemisphere.
  double sun_radius_deg = 0.5;        // Angular radius of the sun disk [deg] (the real sun: 0.27).
  int envmap_height = 256;            // Lat-long height every environment is resampled to, rendered with and written.
  // Cameras.
  int num_photos = 16;             // Photos in the collection.
  double elevation_min_deg = 8;    // Camera elevation above the object's centre, uniform in [min, max] [deg].
  double elevation_max_deg = 45;   // Upper end of the camera elevation [deg].
  double azimuth_jitter_deg = 10;  // Cameras are evenly spaced in azimuth, then jittered by up to this [deg].
  int focal_35mm_min = 28;         // 35 mm-equivalent focal length, uniform integer in [min, max] [mm].
  int focal_35mm_max = 85;         // Upper end of the focal length [mm].
  double object_fill_min =
      0.45;  // Object's bounding-sphere diameter over the shorter image side, uniform in [min, max].
  double object_fill_max = 0.8;  // Upper end of the fill (sets the distance with the focal length).
  int image_size_min = 320;      // Longer image side, uniform integer in [min, max] [px].
  int image_size_max = 400;      // Upper end of the longer image side [px].
  std::vector<double> aspect_ratios = {1.5, 4.0 / 3.0};  // Width over height of landscape photos, drawn in turn.
  double portrait_fraction = 0.25;                       // Fraction of photos held upright (portrait).
  double roll_deg_max = 3;                               // Camera roll uniform in [-max, max] [deg].
  double aim_jitter = 0.05;  // The camera aims at the object's centre plus up to this offset [object sizes].
  std::string camera_model = "SIMPLE_RADIAL";  // COLMAP model of the photos: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL.
  double radial_distortion_max = 0.02;         // SIMPLE_RADIAL k uniform in [-max, max].
  // Rendering.
  int pixel_samples_per_axis = 2;  // Antialiasing: k x k camera rays per pixel.
  int light_samples = 8;           // Environment samples per shading point.
  int brdf_samples = 8;            // BRDF samples per shading point.
  bool interreflection = false;    // Render one bounce of indirect light (the inverse model ignores it).
  int seed = 1;                    // Seed of every random choice and of the renderer.
  // Photography.
  double exposure_key = 0.18;             // Auto-exposure maps the log-average luminance to this sensor value.
  double exposure_jitter_ev = 0.7;        // Exposure offset uniform in [-jitter, jitter] stops.
  std::string white_balance = "auto";     // auto (grey world) or none (daylight gains 1).
  double white_balance_jitter_ev = 0.15;  // Std. dev. of the red and blue gains' error [stops].
  double noise_shot = 4e-4;               // Shot-noise variance per unit sensor value (sensor full scale = 1).
  double noise_read = 2e-3;               // Read-noise standard deviation (sensor full scale = 1).
  int jpeg_quality_min = 80;              // JPEG quality uniform integer in [min, max].
  int jpeg_quality_max = 95;              // Upper end of the JPEG quality.
  double transient_fraction = 0.15;  // Fraction of photos with a transient occluder (a box in front of the object).
  bool exif = true;                  // Write the exact 35 mm-equivalent focal length into EXIF.
  // Ground truth.
  int gt_oct_size = 64;                      // Side of the octahedral ground-truth env maps (power of two).
  int relight_views = 3;                     // Held-out views for relighting references.
  std::vector<std::string> relight_envmaps;  // Held-out lat-long env maps (used unrotated, intensity 1).
  int relight_skies = 2;                     // Held-out procedural skies (drawn like the photos' skies).
  int relight_image_size = 256;              // Side of the square relighting references [px].
  int relight_focal_35mm = 50;               // 35 mm-equivalent focal length of the held-out views [mm].
  int relight_pixel_samples_per_axis = 3;    // Antialiasing of the references.
  int relight_light_samples = 16;            // Environment samples per shading point of the references.
  int relight_brdf_samples = 8;              // BRDF samples per shading point of the references.

  void Declare(OptionTable* t) {
    t->Add("shape", &shape, "Built-in object (ignored when mesh is set).").Choices({"sphere", "torus_knot", "blob"});
    t->Add("mesh", &mesh, "Object mesh file (OBJ/PLY/OFF); empty: the built-in shape.").InputFile();
    t->Add("mesh_up", &mesh_up, "Axis of the mesh file that points up.")
        .Choices({"+x", "-x", "+y", "-y", "+z", "-z"})
        .Advanced();
    t->Add("object_yaw_deg", &object_yaw_deg, "Rotation of the object about +Z after uprighting [deg].").Advanced();
    t->Add("object_size", &object_size, "Largest bounding-box side of the object [scene units].").Min(1e-6).Advanced();
    t->Add("object_vertices", &object_vertices,
           "Built-in shapes get about this many vertices; mesh files are subdivided up to it (never decimated).")
        .Range(100, 5000000)
        .Advanced();
    t->Add("object_max_vertices", &object_max_vertices,
           "Mesh files with more vertices are remeshed down to about this many (CGAL isotropic remeshing; fewer "
           "vertices cover more pixels each, so observations are less noisy); 0: never simplified.")
        .Range(0, 5000000)
        .Advanced();
    t->Add("materials", &materials, "materials.json (docs/FORMATS.md) of the object; empty: the built-in set.")
        .InputFile();
    t->Add("num_materials", &num_materials, "Built-in materials used: terracotta, blue glaze, ivory, brass.")
        .Range(1, 4)
        .Advanced();
    t->Add("pattern", &pattern, "Per-vertex material weight pattern.")
        .Choices({"noise", "voronoi", "single"})
        .Advanced();
    t->Add("pattern_frequency", &pattern_frequency, "Pattern cycles per object size (coarsest octave).")
        .Min(1e-3)
        .Advanced();
    t->Add("pattern_octaves", &pattern_octaves, "Fractal octaves of the noise pattern.").Range(1, 10).Advanced();
    t->Add("pattern_sharpness", &pattern_sharpness, "Softmax gain of the weights (crisper borders when larger).")
        .Min(0)
        .Advanced();
    t->Add("ground", &ground, "Add the textured ground plane z = 0 (casts and receives shadows).");
    t->Add("ground_shape", &ground_shape,
           "square: a square of side ground_size; disk: a round ground of diameter ground_size (no corners "
           "in view).")
        .Choices({"square", "disk"})
        .Advanced()
        .OnlyWhen("ground", {"true"});
    t->Add("ground_size", &ground_size, "Side (square) or diameter (disk) of the ground [object sizes].")
        .Min(1)
        .Advanced()
        .OnlyWhen("ground", {"true"});
    t->Add("ground_cells", &ground_cells,
           "Grid cells per side of the ground (disk: ground_cells / 2 rings); its texture lives on vertices.")
        .Range(1, 4096)
        .Advanced()
        .OnlyWhen("ground", {"true"});
    t->Add("ground_pattern_frequency", &ground_pattern_frequency, "Ground pattern cycles per object size.")
        .Min(1e-3)
        .Advanced()
        .OnlyWhen("ground", {"true"});
    t->Add("ground_pattern", &ground_pattern,
           "Ground texture: mosaic (a random colour per cell with fractal detail, over three primary materials: "
           "distinctive features for structure from motion), noise (the stone materials' fractal pattern) or plain "
           "(the first ground material everywhere: no features but the shadows).")
        .Choices({"mosaic", "noise", "plain"})
        .Advanced()
        .OnlyWhen("ground", {"true"});
    t->Add("ground_materials", &ground_materials,
           "materials.json of the ground and blockers; empty: built-in pale stone, dark stone, sand (Lambertian).")
        .InputFile()
        .Advanced()
        .OnlyWhen("ground", {"true"});
    t->Add("num_blockers", &num_blockers, "Boxes standing beside the object that cast shadows on it.").Range(0, 16);
    t->Add("blocker_height", &blocker_height, "Height of a blocker [object sizes].").Min(1e-3).Advanced();
    t->Add("blocker_width", &blocker_width, "Side of a blocker's square footprint [object sizes].")
        .Range(1e-3, 10)
        .Advanced();
    t->Add("blocker_distance", &blocker_distance, "Distance of a blocker from the object's axis [object sizes].")
        .Min(0.5)
        .Advanced();
    t->Add("envmaps", &envmaps, "Lat-long HDR/EXR environment maps of the photos; empty: procedural sky only.")
        .InputFile();
    t->Add("sky_fraction", &sky_fraction,
           "Fraction of lighting conditions from the sun-and-sky model (all of them when envmaps is empty).")
        .Range(0, 1)
        .Advanced();
    t->Add("num_lightings", &num_lightings,
           "Distinct lighting conditions, assigned to the photos in turn; 0: one per photo.")
        .Min(0);
    t->Add("lighting_order", &lighting_order,
           "With fewer lightings than photos: interleaved (photo p gets lighting p mod L, neighbours differ) or "
           "blocks (runs of neighbouring views share one lighting, so structure from motion can chain them).")
        .Choices({"interleaved", "blocks"})
        .Advanced();
    t->Add("env_rotation_deg", &env_rotation_deg, "Env-map rotation about +Z, uniform in [0, this) [deg].")
        .Range(0, 360)
        .Advanced();
    t->Add("intensity_min", &intensity_min, "Light intensity scale, log-uniform in [intensity_min, intensity_max].")
        .Min(1e-9)
        .Advanced();
    t->Add("intensity_max", &intensity_max, "Upper end of the light intensity scale.").Min(1e-9).Advanced();
    t->Add("sun_elevation_min_deg", &sun_elevation_min_deg, "Lowest sun elevation [deg].").Range(0, 90).Advanced();
    t->Add("sun_elevation_max_deg", &sun_elevation_max_deg, "Highest sun elevation [deg].").Range(0, 90).Advanced();
    t->Add("turbidity_min", &turbidity_min, "Lowest Preetham turbidity (1.7 clear .. 10 hazy).")
        .Range(1.7, 10)
        .Advanced();
    t->Add("turbidity_max", &turbidity_max, "Highest Preetham turbidity.").Range(1.7, 10).Advanced();
    t->Add("sky_ground_albedo", &sky_ground_albedo, "Albedo of the sky model's lower hemisphere.")
        .Range(0, 1)
        .Advanced();
    t->Add("sun_radius_deg", &sun_radius_deg, "Angular radius of the sun disk [deg] (the real sun: 0.27).")
        .Range(0.05, 10)
        .Advanced();
    t->Add("envmap_height", &envmap_height,
           "Lat-long height every environment is resampled to, rendered with and written (width = 2 x height).")
        .Range(16, 4096)
        .Advanced();
    t->Add("num_photos", &num_photos, "Photos in the collection.").Range(1, 100000);
    t->Add("elevation_min_deg", &elevation_min_deg, "Lowest camera elevation above the object's centre [deg].")
        .Range(-30, 89)
        .Advanced();
    t->Add("elevation_max_deg", &elevation_max_deg, "Highest camera elevation [deg].").Range(-30, 89).Advanced();
    t->Add("azimuth_jitter_deg", &azimuth_jitter_deg, "Jitter of the evenly spaced camera azimuths [deg].")
        .Range(0, 180)
        .Advanced();
    t->Add("focal_35mm_min", &focal_35mm_min, "Shortest 35 mm-equivalent focal length [mm].").Range(8, 1200).Advanced();
    t->Add("focal_35mm_max", &focal_35mm_max, "Longest 35 mm-equivalent focal length [mm].").Range(8, 1200).Advanced();
    t->Add("object_fill_min", &object_fill_min, "Smallest object bounding-sphere diameter over the shorter image side.")
        .Range(0.05, 1.5)
        .Advanced();
    t->Add("object_fill_max", &object_fill_max, "Largest object fill.").Range(0.05, 1.5).Advanced();
    t->Add("image_size_min", &image_size_min, "Shortest longer image side [px].").Range(16, 16384).Advanced();
    t->Add("image_size_max", &image_size_max, "Longest longer image side [px].").Range(16, 16384).Advanced();
    t->Add("aspect_ratios", &aspect_ratios, "Width over height of landscape photos, drawn in turn.").Advanced();
    t->Add("portrait_fraction", &portrait_fraction, "Fraction of photos held upright (portrait).")
        .Range(0, 1)
        .Advanced();
    t->Add("roll_deg_max", &roll_deg_max, "Camera roll uniform in [-max, max] [deg].").Range(0, 45).Advanced();
    t->Add("aim_jitter", &aim_jitter, "Random offset of the aim point from the object's centre [object sizes].")
        .Range(0, 1)
        .Advanced();
    t->Add("camera_model", &camera_model, "COLMAP camera model of the photos.")
        .Choices({"SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL"})
        .Advanced();
    t->Add("radial_distortion_max", &radial_distortion_max, "SIMPLE_RADIAL k uniform in [-max, max].")
        .Range(0, 0.3)
        .Advanced()
        .OnlyWhen("camera_model", {"SIMPLE_RADIAL"});
    t->Add("pixel_samples_per_axis", &pixel_samples_per_axis, "Antialiasing: k x k camera rays per pixel.")
        .Range(1, 16)
        .Advanced();
    t->Add("light_samples", &light_samples, "Environment importance samples per shading point.")
        .Range(0, 4096)
        .Advanced();
    t->Add("brdf_samples", &brdf_samples, "BRDF importance samples per shading point.").Range(0, 4096).Advanced();
    t->Add("interreflection", &interreflection, "Render one bounce of indirect light.").Advanced();
    t->Add("seed", &seed, "Seed of every random choice and of the renderer.").Min(0);
    t->Add("exposure_key", &exposure_key, "Auto-exposure maps the log-average luminance to this sensor value.")
        .Range(1e-4, 1)
        .Advanced();
    t->Add("exposure_jitter_ev", &exposure_jitter_ev, "Exposure offset uniform in [-jitter, jitter] stops.")
        .Range(0, 10)
        .Advanced();
    t->Add("white_balance", &white_balance, "White balance: auto (grey world) or none (gains 1).")
        .Choices({"auto", "none"})
        .Advanced();
    t->Add("white_balance_jitter_ev", &white_balance_jitter_ev,
           "Standard deviation of the red and blue gains' error [stops].")
        .Range(0, 2)
        .Advanced();
    t->Add("noise_shot", &noise_shot, "Shot-noise variance per unit sensor value (full scale 1).")
        .Range(0, 0.1)
        .Advanced();
    t->Add("noise_read", &noise_read, "Read-noise standard deviation (full scale 1).").Range(0, 0.5).Advanced();
    t->Add("jpeg_quality_min", &jpeg_quality_min, "Lowest JPEG quality.").Range(10, 100).Advanced();
    t->Add("jpeg_quality_max", &jpeg_quality_max, "Highest JPEG quality.").Range(10, 100).Advanced();
    t->Add("transient_fraction", &transient_fraction,
           "Fraction of photos with a transient occluder (a box between camera and object).")
        .Range(0, 1);
    t->Add("exif", &exif, "Write the exact 35 mm-equivalent focal length into the photos' EXIF.").Advanced();
    t->Add("gt_oct_size", &gt_oct_size, "Side of the octahedral ground-truth env maps (power of two).")
        .Range(4, 1024)
        .Advanced();
    t->Add("relight_views", &relight_views, "Held-out views of the relighting references.").Range(0, 64).Advanced();
    t->Add("relight_envmaps", &relight_envmaps, "Held-out lat-long env maps (unrotated, intensity 1).")
        .InputFile()
        .Advanced();
    t->Add("relight_skies", &relight_skies, "Held-out procedural skies.").Range(0, 64).Advanced();
    t->Add("relight_image_size", &relight_image_size, "Side of the square relighting references [px].")
        .Range(16, 8192)
        .Advanced();
    t->Add("relight_focal_35mm", &relight_focal_35mm, "35 mm-equivalent focal length of the held-out views [mm].")
        .Range(8, 1200)
        .Advanced();
    t->Add("relight_pixel_samples_per_axis", &relight_pixel_samples_per_axis, "Antialiasing of the references.")
        .Range(1, 16)
        .Advanced();
    t->Add("relight_light_samples", &relight_light_samples, "Environment samples per shading point (references).")
        .Range(0, 4096)
        .Advanced();
    t->Add("relight_brdf_samples", &relight_brdf_samples, "BRDF samples per shading point (references).")
        .Range(0, 4096)
        .Advanced();
  }

  void Check() const {
    auto ordered = [](double lo, double hi, const char* a, const char* b) {
      if (lo > hi)
        RELIGHT_USER_ERROR() << "synthesize." << a << " (" << lo << ") exceeds synthesize." << b << " (" << hi << ")";
    };
    ordered(intensity_min, intensity_max, "intensity_min", "intensity_max");
    ordered(sun_elevation_min_deg, sun_elevation_max_deg, "sun_elevation_min_deg", "sun_elevation_max_deg");
    ordered(turbidity_min, turbidity_max, "turbidity_min", "turbidity_max");
    ordered(elevation_min_deg, elevation_max_deg, "elevation_min_deg", "elevation_max_deg");
    ordered(focal_35mm_min, focal_35mm_max, "focal_35mm_min", "focal_35mm_max");
    ordered(object_fill_min, object_fill_max, "object_fill_min", "object_fill_max");
    ordered(image_size_min, image_size_max, "image_size_min", "image_size_max");
    ordered(jpeg_quality_min, jpeg_quality_max, "jpeg_quality_min", "jpeg_quality_max");
    if (aspect_ratios.empty())
      RELIGHT_USER_ERROR() << "synthesize.aspect_ratios is empty; give at least one, e.g. [1.5]";
    for (double a : aspect_ratios)
      if (!(a >= 1 && a <= 4))
        RELIGHT_USER_ERROR() << "synthesize.aspect_ratios: " << a << " is not in [1, 4] (landscape width / height)";
    if (gt_oct_size & (gt_oct_size - 1))
      RELIGHT_USER_ERROR() << "synthesize.gt_oct_size = " << gt_oct_size << " is not a power of two";
    if (light_samples + brdf_samples < 1)
      RELIGHT_USER_ERROR() << "synthesize.light_samples + brdf_samples must be at least 1";
    if (relight_light_samples + relight_brdf_samples < 1)
      RELIGHT_USER_ERROR() << "synthesize.relight_light_samples + relight_brdf_samples must be at least 1";
    if (interreflection && brdf_samples < 1)
      RELIGHT_USER_ERROR() << "synthesize.interreflection needs brdf_samples >= 1";
    if (num_blockers > 0 && !ground)
      RELIGHT_USER_ERROR() << "synthesize.num_blockers > 0 needs ground: true (blockers stand on the ground)";
    if (ground && elevation_min_deg < 0)
      RELIGHT_USER_ERROR() << "synthesize.elevation_min_deg = " << elevation_min_deg
                           << " would put cameras below the ground plane; use >= 0 or ground: false";
    if (relight_views > 0 && relight_envmaps.empty() && relight_skies == 0)
      RELIGHT_USER_ERROR() << "synthesize.relight_views > 0 but there is no held-out lighting: set relight_envmaps or "
                              "relight_skies (or relight_views: 0)";
  }
};

}  // namespace relight
