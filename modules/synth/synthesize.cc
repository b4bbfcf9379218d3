#include "synth/synthesize.h"

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <memory>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "geometry/mesh_io.h"
#include "image/image.h"
#include "render/lighting.h"
#include "render/render_view.h"
#include "synth/illumination.h"
#include "synth/materials.h"
#include "synth/photography.h"
#include "synth/shapes.h"

namespace relight {
namespace {

// Independent random streams, so that changing one aspect of the collection
// (say, the number of photos) leaves the others (the object's pattern) alone.
enum Stream : uint64_t {
  kStreamObject = 1,
  kStreamObjectPattern = 2,
  kStreamGroundPattern = 3,
  kStreamBlockers = 4,
  kStreamCameras = 5,
  kStreamLighting = 6,
  kStreamHeldOut = 7,
  kStreamPhoto = 1000,        // + photo index
  kStreamTransient = 500000,  // + photo index
};

std::string Stem(const std::string& name) { return std::filesystem::path(name).stem().string(); }

void WriteFloat(const std::string& path, const Image& image) {
  WriteOptions options;
  options.type = PixelType::kFloat;
  WriteImage(path, image, options);
}

// 8-bit mask: 255 where the pixel-centre ray hits the object.
void WriteMask(const std::string& path, const Image& mask) { WriteImage(path, mask); }

RenderOptions PhotoRenderOptions(const SynthesizeOptions& o) {
  RenderOptions r;
  r.pixel_samples_per_axis = o.pixel_samples_per_axis;
  r.light_samples = o.light_samples;
  r.brdf_samples = o.brdf_samples;
  r.interreflection = o.interreflection;
  r.seed = MixSeed(uint64_t(o.seed), 0xF070);
  return r;
}

RenderOptions ReferenceRenderOptions(const SynthesizeOptions& o) {
  RenderOptions r = PhotoRenderOptions(o);
  r.pixel_samples_per_axis = o.relight_pixel_samples_per_axis;
  r.light_samples = o.relight_light_samples;
  r.brdf_samples = o.relight_brdf_samples;
  r.seed = MixSeed(uint64_t(o.seed), 0x4E1167);
  return r;
}

OrderedJson Vec(const Eigen::Vector3d& v) { return OrderedJson::array({v.x(), v.y(), v.z()}); }

// Lists albedo_r/g/b first, then w0 … (the order docs/FORMATS.md shows).
void OrderProperties(TriangleMesh* mesh) {
  std::stable_sort(mesh->properties.begin(), mesh->properties.end(), [](const auto& a, const auto& b) {
    const bool albedo_a = a.first.rfind("albedo_", 0) == 0, albedo_b = b.first.rfind("albedo_", 0) == 0;
    return albedo_a && !albedo_b;
  });
}

// A user's materials.json, with errors that say which option and what to do.
ReflectanceModel ReadMaterialsFile(const std::string& path, const char* key) {
  try {
    return ReadReflectanceModel(path);
  } catch (const UserError& e) {
    RELIGHT_USER_ERROR() << "synthesize." << key << ": " << e.what()
                         << " -- fix the file (format: docs/FORMATS.md, materials.json)";
  }
}

}  // namespace

SyntheticScene BuildSyntheticScene(const SynthesizeOptions& o) {
  SyntheticScene s;
  TriangleMesh& object = s.object;
  if (!o.mesh.empty()) {
    object = ReadMesh(o.mesh);
    if (object.empty()) {
      RELIGHT_USER_ERROR() << "mesh file '" << o.mesh << "' has no triangles; set synthesize.mesh to a triangle mesh "
                           << "(OBJ/PLY/OFF) or leave it empty for the built-in shape";
    }
    object.Check(o.mesh);
    object.normals.clear();
    object.colors.clear();
    object.properties.clear();
    const size_t file_vertices = object.num_vertices();
    if (SimplifyToVertices(&object, o.object_max_vertices, o.mesh)) {
      RLOG_INFO("object mesh remeshed from {} to {} vertices (synthesize.object_max_vertices)", file_vertices,
                object.num_vertices());
    }
    RotateUp(&object, o.mesh_up, o.object_yaw_deg);
    NormalizeOntoGround(&object, o.object_size);
    object.ComputeVertexNormals();
    SubdivideToVertices(&object, o.object_vertices);
  } else {
    object = MakeShape(o.shape, o.object_vertices, MixSeed(uint64_t(o.seed), kStreamObject));
    RotateUp(&object, "+z", o.object_yaw_deg);
    NormalizeOntoGround(&object, o.object_size);
  }
  BoundingSphere(object, &s.center, &s.radius);

  s.object_reflectance =
      o.materials.empty() ? BuiltinObjectMaterials(o.num_materials) : ReadMaterialsFile(o.materials, "materials");
  if (s.object_reflectance.materials.empty() || s.object_reflectance.basis.empty()) {
    RELIGHT_USER_ERROR() << "materials file '" << o.materials << "' has no basis BRDFs or no materials";
  }
  if (static_cast<int>(s.object_reflectance.basis.size()) > kMaxLobes) {
    RELIGHT_USER_ERROR() << "materials file '" << o.materials << "' has " << s.object_reflectance.basis.size()
                         << " basis BRDFs; the renderer supports at most " << kMaxLobes;
  }
  WeightPattern pattern;
  pattern.kind = o.pattern;
  pattern.frequency = o.pattern_frequency / o.object_size;
  pattern.octaves = o.pattern_octaves;
  pattern.sharpness = o.pattern_sharpness;
  pattern.seed = MixSeed(uint64_t(o.seed), kStreamObjectPattern);
  AssignMaterialWeights(s.object_reflectance, pattern, &object);
  OrderProperties(&object);

  if (o.ground) {
    s.occluders = o.ground_shape == "disk" ? MakeGroundDisk(o.ground_size * o.object_size, std::max(1, o.ground_cells / 2))
                                           : MakeGroundPlane(o.ground_size * o.object_size, o.ground_cells);
    Pcg32 rng(uint64_t(o.seed), kStreamBlockers);
    const double phase = rng.Uniform(0, 2 * M_PI);
    double radius_xy = 0;
    for (const auto& v : object.vertices) radius_xy = std::max(radius_xy, double(v.head<2>().norm()));
    for (int b = 0; b < o.num_blockers; ++b) {
      const double half = 0.5 * o.blocker_width * o.object_size;
      const double distance = std::max(o.blocker_distance * o.object_size, radius_xy + 1.5 * half);
      const double angle = phase + 2 * M_PI * b / o.num_blockers;
      const Eigen::Vector3d c(distance * std::cos(angle), distance * std::sin(angle), 0.0);
      s.blocker_azimuths_deg.push_back(std::fmod(angle * 180 / M_PI, 360.0));
      s.occluders.Append(MakeBox(c - Eigen::Vector3d(half, half, 0),
                                 c + Eigen::Vector3d(half, half, o.blocker_height * o.object_size), 16));
    }
    s.occluder_reflectance = !o.ground_materials.empty() ? ReadMaterialsFile(o.ground_materials, "ground_materials")
                             : o.ground_pattern == "mosaic" ? BuiltinPrimaryMaterials()
                                                            : BuiltinGroundMaterials();
    if (s.occluder_reflectance.materials.empty() || s.occluder_reflectance.basis.empty() ||
        int(s.occluder_reflectance.basis.size()) > kMaxLobes) {
      RELIGHT_USER_ERROR() << "synthesize.ground_materials: '" << o.ground_materials << "' needs 1 to " << kMaxLobes
                           << " basis BRDFs and at least one material";
    }
    WeightPattern ground_pattern = pattern;
    ground_pattern.kind = o.ground_pattern == "plain" ? "single" : o.ground_pattern;
    ground_pattern.frequency = o.ground_pattern_frequency / o.object_size;
    ground_pattern.seed = MixSeed(uint64_t(o.seed), kStreamGroundPattern);
    AssignMaterialWeights(s.occluder_reflectance, ground_pattern, &s.occluders);
    OrderProperties(&s.occluders);
  }
  return s;
}

std::vector<Scene::Surface> SceneSurfaces(const SyntheticScene& scene) {
  std::vector<Scene::Surface> surfaces;
  surfaces.push_back({scene.object, scene.object_reflectance, SurfaceRole::kObject});
  if (!scene.occluders.empty())
    surfaces.push_back({scene.occluders, scene.occluder_reflectance, SurfaceRole::kOccluder});
  return surfaces;
}

Scene::Surface MakeTransientOccluder(const SyntheticScene& scene, const SyntheticView& view, double object_size,
                                     Pcg32* rng) {
  const Eigen::Vector3d camera = view.pose.ProjectionCenter();
  double radius_xy = 0;
  for (const auto& v : scene.object.vertices)
    radius_xy = std::max(radius_xy, (v.cast<double>() - scene.center).head<2>().norm());
  const double half_width = rng->Uniform(0.05, 0.12) * object_size, half_depth = 0.06 * object_size;
  // Somewhere between 35% and 60% of the way from the camera to the object, shifted sideways.
  Eigen::Vector2d to_object = (scene.center - camera).head<2>();
  const double length = to_object.norm();
  to_object /= length;
  const Eigen::Vector2d side(-to_object.y(), to_object.x());
  double t = rng->Uniform(0.35, 0.6);
  const double lateral = rng->Uniform(-0.25, 0.25) * object_size;
  Eigen::Vector2d foot = camera.head<2>() + t * length * to_object + lateral * side;
  // Keep clear of the object.
  const double clearance = radius_xy + half_width + half_depth;
  while ((foot - scene.center.head<2>()).norm() < clearance && t > 0.05) {
    t -= 0.05;
    foot = camera.head<2>() + t * length * to_object + lateral * side;
  }
  // Tall enough to reach the line of sight from the camera to the object's centre, so it hides part of it.
  const double line_of_sight_z = camera.z() + t * (scene.center.z() - camera.z());
  const double height = std::max(0.2 * object_size, line_of_sight_z + rng->Uniform(-0.1, 0.15) * object_size);
  TriangleMesh box =
      MakeBox(Eigen::Vector3d(-half_depth, -half_width, 0), Eigen::Vector3d(half_depth, half_width, height), 1);
  const double yaw = std::atan2(to_object.y(), to_object.x());
  const Eigen::Matrix3f r = Eigen::AngleAxisf(float(yaw), Eigen::Vector3f::UnitZ()).toRotationMatrix();
  for (auto& v : box.vertices) v = r * v + Eigen::Vector3f(float(foot.x()), float(foot.y()), 0.0f);
  for (auto& n : box.normals) n = r * n;
  static const Eigen::Vector3d kColours[] = {{0.60, 0.08, 0.06}, {0.70, 0.60, 0.10}, {0.10, 0.20, 0.60},
                                             {0.80, 0.80, 0.80}, {0.04, 0.04, 0.04}, {0.15, 0.45, 0.15}};
  const Eigen::Vector3d albedo = kColours[rng->UniformInt(6)];
  return {box, LambertianModel(albedo, "transient"), SurfaceRole::kOccluder};
}

std::string SynthesizeSummary::BriefReport() const {
  std::ostringstream s;
  s << "synthesize: " << num_photos << " photos under " << num_lightings << " lighting conditions (" << num_transient
    << " with a transient occluder), " << num_relight_renders << " relighting references; object " << object_vertices
    << " vertices, occluders " << occluder_vertices << " vertices; scene " << Progress::FormatSeconds(seconds_scene)
    << ", lighting " << Progress::FormatSeconds(seconds_lighting) << ", photos "
    << Progress::FormatSeconds(seconds_render) << ", references " << Progress::FormatSeconds(seconds_relight)
    << ", total " << Progress::FormatSeconds(seconds_total);
  return s.str();
}

OrderedJson SynthesizeSummary::ToJson() const {
  OrderedJson j;
  j["num_photos"] = num_photos;
  j["num_lightings"] = num_lightings;
  j["num_transient"] = num_transient;
  j["num_relight_renders"] = num_relight_renders;
  j["object_vertices"] = object_vertices;
  j["object_faces"] = object_faces;
  j["occluder_vertices"] = occluder_vertices;
  j["seconds"] = {{"scene", seconds_scene},
                  {"lighting", seconds_lighting},
                  {"render_photos", seconds_render},
                  {"render_references", seconds_relight},
                  {"total", seconds_total}};
  j["photos"] = photos;
  return j;
}

// Fails fast, before any expensive work, when an input file is missing or unreadable.
static void CheckInputFiles(const SynthesizeOptions& o) {
  auto check_image = [](const std::string& path, const char* key) {
    if (!std::filesystem::is_regular_file(path)) {
      RELIGHT_USER_ERROR() << "synthesize." << key << ": environment map '" << path
                           << "' does not exist; fix the path (relative paths are relative to the config file)";
    }
    ImageMetadata meta;
    try {
      meta = ReadImageMetadata(path);
    } catch (const UserError& e) {
      RELIGHT_USER_ERROR() << "synthesize." << key << ": cannot use environment map '" << path << "' (" << e.what()
                           << "); give a lat-long HDR/EXR file";
    }
    if (meta.width != 2 * meta.height) {
      RELIGHT_USER_ERROR() << "synthesize." << key << ": environment map '" << path << "' is " << meta.width << "x"
                           << meta.height << ", not a 2:1 lat-long (equirectangular) map; convert it";
    }
  };
  for (const auto& path : o.envmaps) check_image(path, "envmaps");
  for (const auto& path : o.relight_envmaps) check_image(path, "relight_envmaps");
  for (const auto& [path, key] : {std::pair{o.mesh, "mesh"}, std::pair{o.materials, "materials"},
                                  std::pair{o.ground_materials, "ground_materials"}}) {
    if (!path.empty() && !std::filesystem::is_regular_file(path)) {
      RELIGHT_USER_ERROR() << "synthesize." << key << ": file '" << path
                           << "' does not exist; fix the path (relative paths are relative to the config file)";
    }
  }
}

SynthesizeSummary RunSynthesize(const SynthesizeOptions& o, const std::string& output_dir) {
  o.Check();
  CheckInputFiles(o);
  Timer total;
  SynthesizeSummary summary;
  const std::string images_dir = JoinPath(output_dir, "images");
  const std::string gt = JoinPath(output_dir, "ground_truth");
  for (const char* sub : {"envmaps", "depth", "masks", "linear"}) EnsureDir(JoinPath(gt, sub));
  EnsureDir(images_dir);

  // Scene.
  Timer timer;
  const SyntheticScene scene = BuildSyntheticScene(o);
  summary.object_vertices = scene.object.num_vertices();
  summary.object_faces = scene.object.num_faces();
  summary.occluder_vertices = scene.occluders.num_vertices();
  const Scene static_scene(SceneSurfaces(scene), "synthetic scene");
  summary.seconds_scene = timer.Seconds();
  RLOG_INFO("scene: object {} vertices / {} faces ({}), occluders {} vertices, {} materials, {} basis BRDFs; {}",
            scene.object.num_vertices(), scene.object.num_faces(), o.mesh.empty() ? o.shape : o.mesh,
            scene.occluders.num_vertices(), scene.object_reflectance.materials.size(),
            scene.object_reflectance.basis.size(), Progress::FormatSeconds(summary.seconds_scene));

  // Cameras and lighting conditions.
  Pcg32 camera_rng(uint64_t(o.seed), kStreamCameras);
  const std::vector<SyntheticView> views = PlacePhotoCameras(o, scene.center, scene.radius, &camera_rng);
  const int num_lightings = o.num_lightings > 0 ? std::min(o.num_lightings, o.num_photos) : o.num_photos;
  Pcg32 lighting_rng(uint64_t(o.seed), kStreamLighting);
  const std::vector<LightingCondition> conditions = DrawPhotoLightings(o, num_lightings, &lighting_rng);
  timer.Restart();
  EnvMapCache cache;
  std::vector<Image> latlong(num_lightings), octahedral(num_lightings);
  std::vector<Lighting> lightings(num_lightings);
  for (int i = 0; i < num_lightings; ++i) {
    latlong[i] = RenderLightingLatLong(conditions[i], o.envmap_height, &cache);
    const EnvMap env = EnvMap::FromLatLong(latlong[i]);
    octahedral[i] = env.ToOctahedral(o.gt_oct_size);
    lightings[i] = Lighting::FromEnvMap(env);
  }
  summary.seconds_lighting = timer.Seconds();
  summary.num_lightings = num_lightings;
  RLOG_INFO("lighting: {} conditions ({} from files), lat-long {}x{}; {}", num_lightings,
            std::count_if(conditions.begin(), conditions.end(), [](const auto& c) { return c.source == "file"; }),
            2 * o.envmap_height, o.envmap_height, Progress::FormatSeconds(summary.seconds_lighting));

  // Photos with a transient occluder, spread over the collection.
  std::vector<bool> transient(o.num_photos, false);
  const int num_transient = int(std::lround(o.transient_fraction * o.num_photos));
  for (int k = 0; k < num_transient; ++k) transient[int((k + 0.5) * o.num_photos / num_transient)] = true;
  summary.num_transient = num_transient;

  // Render and develop the photos.
  const RenderOptions render_options = PhotoRenderOptions(o);
  PhotoStyle style;
  style.auto_white_balance = o.white_balance == "auto";
  style.white_balance_jitter_ev = o.white_balance_jitter_ev;
  style.exposure_key = o.exposure_key;
  style.exposure_jitter_ev = o.exposure_jitter_ev;
  style.noise_shot = o.noise_shot;
  style.noise_read = o.noise_read;
  style.jpeg_quality_min = o.jpeg_quality_min;
  style.jpeg_quality_max = o.jpeg_quality_max;
  int64_t tiles = 0;
  for (const auto& v : views) tiles += NumTiles(v.camera, render_options);
  timer.Restart();
  OrderedJson lighting_photos = OrderedJson::array();
  {
    Progress progress("render photos", tiles);
    for (int p = 0; p < o.num_photos; ++p) {
      const SyntheticView& view = views[p];
      // Photos are placed in azimuth order; "blocks" gives neighbouring views the same light.
      const int li = o.lighting_order == "blocks" ? p * num_lightings / o.num_photos : p % num_lightings;
      std::unique_ptr<Scene> transient_scene;
      if (transient[p]) {
        Pcg32 rng(uint64_t(o.seed), kStreamTransient + p);
        std::vector<Scene::Surface> surfaces = SceneSurfaces(scene);
        surfaces.push_back(MakeTransientOccluder(scene, view, o.object_size, &rng));
        transient_scene = std::make_unique<Scene>(std::move(surfaces), "synthetic scene with transient occluder");
      }
      const Scene& render_scene = transient_scene ? *transient_scene : static_scene;
      const RenderedView rendered =
          RenderView(render_scene, lightings[li], view.camera, view.pose, render_options, uint64_t(p), &progress);
      Pcg32 photo_rng(uint64_t(o.seed), kStreamPhoto + p);
      const PhotoSettings settings = ChoosePhotoSettings(rendered.radiance, style, &photo_rng);
      double clipped = 0;
      const Image photo = DevelopPhoto(rendered.radiance, settings, &photo_rng, &clipped);
      ImageMetadata exif;
      exif.focal_length_mm = view.focal_35mm;
      exif.focal_length_35mm = view.focal_35mm;
      exif.camera_make = "relight";
      exif.camera_model = "synthesize (full frame)";
      WriteOptions write;
      write.type = PixelType::kUint8;
      write.jpeg_quality = settings.jpeg_quality;
      write.exif = o.exif ? &exif : nullptr;
      WriteImage(JoinPath(images_dir, view.name), photo, write);
      const std::string stem = Stem(view.name);
      WriteFloat(JoinPath(gt, "linear/" + stem + ".exr"), rendered.radiance);
      WriteFloat(JoinPath(gt, "depth/" + stem + ".exr"), rendered.depth);
      WriteMask(JoinPath(gt, "masks/" + stem + ".png"), rendered.mask);
      WriteFloat(JoinPath(gt, "envmaps/" + stem + "_latlong.exr"), latlong[li]);
      WriteFloat(JoinPath(gt, "envmaps/" + stem + "_oct.exr"), octahedral[li]);

      double mask_fraction = 0;
      for (float m : rendered.mask.pixels) mask_fraction += m;
      mask_fraction /= rendered.mask.pixels.size();
      OrderedJson entry;
      entry["name"] = view.name;
      entry["lighting"] = conditions[li].name;
      entry["environment"] = LightingConditionToJson(conditions[li]);
      entry["envmap_latlong"] = "envmaps/" + stem + "_latlong.exr";
      entry["envmap_oct"] = "envmaps/" + stem + "_oct.exr";
      entry["exposure"] = settings.exposure;
      entry["white_balance"] = Vec(settings.white_balance);
      entry["exposure_offset_ev"] = settings.exposure_offset_ev;
      entry["noise_shot"] = settings.noise_shot;
      entry["noise_read"] = settings.noise_read;
      entry["jpeg_quality"] = settings.jpeg_quality;
      entry["clipped_fraction"] = clipped;
      entry["transient_occluder"] = bool(transient[p]);
      entry["linear"] = "linear/" + stem + ".exr";
      entry["depth"] = "depth/" + stem + ".exr";
      entry["mask"] = "masks/" + stem + ".png";
      lighting_photos.push_back(entry);

      OrderedJson s;
      s["name"] = view.name;
      s["width"] = view.camera.width;
      s["height"] = view.camera.height;
      s["focal_35mm"] = view.focal_35mm;
      s["azimuth_deg"] = view.azimuth_deg;
      s["elevation_deg"] = view.elevation_deg;
      s["distance"] = view.distance;
      s["lighting"] = conditions[li].name;
      s["exposure_offset_ev"] = settings.exposure_offset_ev;
      s["clipped_fraction"] = clipped;
      s["object_fraction"] = mask_fraction;
      s["transient_occluder"] = bool(transient[p]);
      s["seconds"] = rendered.seconds;
      summary.photos.push_back(s);
      LogFileOnly(fmt::format("{}: {}x{}, {} mm, {}, clipped {:.2f}%, {:.1f}s", view.name, view.camera.width,
                              view.camera.height, view.focal_35mm, conditions[li].name, 100 * clipped,
                              rendered.seconds));
    }
  }
  summary.num_photos = o.num_photos;
  summary.seconds_render = timer.Seconds();

  // Static ground truth.
  ViewsToReconstruction(views).WriteText(gt);
  WriteMeshPly(JoinPath(gt, "mesh.ply"), scene.object);
  WriteReflectanceModel(JoinPath(gt, "materials.json"), scene.object_reflectance);
  if (!scene.occluders.empty()) {
    WriteMeshPly(JoinPath(gt, "occluders.ply"), scene.occluders);
    WriteReflectanceModel(JoinPath(gt, "occluder_materials.json"), scene.occluder_reflectance);
  }
  OrderedJson lighting_json;
  lighting_json["format"] = "relight-lighting";
  lighting_json["version"] = 1;
  lighting_json["photo_model"] =
      "encoded = srgb(clamp(exposure * white_balance[c] * linear[c] + noise, 0, 1)), "
      "noise ~ N(0, noise_shot * sensor + noise_read^2)";
  lighting_json["envmap_height"] = o.envmap_height;
  lighting_json["oct_size"] = o.gt_oct_size;
  lighting_json["lightings"] = OrderedJson::array();
  for (const auto& c : conditions) lighting_json["lightings"].push_back(LightingConditionToJson(c));
  lighting_json["photos"] = lighting_photos;
  WriteJsonAtomic(JoinPath(gt, "lighting.json"), lighting_json);

  // Relighting references: held-out views x held-out lighting, linear, no photography.
  timer.Restart();
  // Held-out views keep away from the photos' azimuths and look past the blockers.
  std::vector<double> azimuths = scene.blocker_azimuths_deg;
  for (const auto& v : views) azimuths.push_back(v.azimuth_deg);
  const std::vector<SyntheticView> held_views = PlaceHeldOutCameras(o, scene.center, scene.radius, azimuths);
  Pcg32 held_rng(uint64_t(o.seed), kStreamHeldOut);
  const std::vector<LightingCondition> held_lights =
      held_views.empty() ? std::vector<LightingCondition>() : DrawHeldOutLightings(o, &held_rng);
  const std::string relight_dir = JoinPath(gt, "relight");
  if (!held_views.empty() && !held_lights.empty()) {
    EnsureDir(JoinPath(relight_dir, "envmaps"));
    const RenderOptions reference_options = ReferenceRenderOptions(o);
    OrderedJson index;
    index["format"] = "relight-references";
    index["version"] = 1;
    index["units"] = "linear radiance (no exposure, white balance, noise or clipping)";
    index["views"] = OrderedJson::array();
    index["envmaps"] = OrderedJson::array();
    index["envmap_details"] = OrderedJson::array();
    index["renders"] = OrderedJson::array();
    for (const auto& v : held_views) index["views"].push_back(v.name);
    std::vector<Lighting> held_lighting;
    for (const auto& c : held_lights) {
      const Image image = RenderLightingLatLong(c, o.envmap_height, &cache);
      const EnvMap env = EnvMap::FromLatLong(image);
      WriteFloat(JoinPath(relight_dir, "envmaps/" + c.name + "_latlong.exr"), image);
      WriteFloat(JoinPath(relight_dir, "envmaps/" + c.name + "_oct.exr"), env.ToOctahedral(o.gt_oct_size));
      held_lighting.push_back(Lighting::FromEnvMap(env));
      index["envmaps"].push_back(c.name);
      OrderedJson d = LightingConditionToJson(c);
      d["latlong"] = "envmaps/" + c.name + "_latlong.exr";
      d["oct"] = "envmaps/" + c.name + "_oct.exr";
      index["envmap_details"].push_back(d);
    }
    int64_t held_tiles = 0;
    for (const auto& v : held_views) held_tiles += NumTiles(v.camera, reference_options) * int64_t(held_lights.size());
    Progress progress("render relighting references", held_tiles);
    for (size_t v = 0; v < held_views.size(); ++v) {
      for (size_t e = 0; e < held_lights.size(); ++e) {
        const RenderedView rendered =
            RenderView(static_scene, held_lighting[e], held_views[v].camera, held_views[v].pose, reference_options,
                       uint64_t(v * held_lights.size() + e), &progress);
        const std::string image = held_views[v].name + "__" + held_lights[e].name + ".exr";
        WriteFloat(JoinPath(relight_dir, image), rendered.radiance);
        if (e == 0) {
          WriteMask(JoinPath(relight_dir, held_views[v].name + "_mask.png"), rendered.mask);
          WriteFloat(JoinPath(relight_dir, held_views[v].name + "_depth.exr"), rendered.depth);
        }
        index["renders"].push_back({{"view", held_views[v].name},
                                    {"envmap", held_lights[e].name},
                                    {"image", image},
                                    {"mask", held_views[v].name + "_mask.png"},
                                    {"depth", held_views[v].name + "_depth.exr"}});
        ++summary.num_relight_renders;
      }
    }
    ViewsToReconstruction(held_views).WriteText(relight_dir);
    WriteJsonAtomic(JoinPath(relight_dir, "index.json"), index);
  }
  summary.seconds_relight = timer.Seconds();
  summary.seconds_total = total.Seconds();
  WriteJsonAtomic(JoinPath(output_dir, "summary.json"), summary.ToJson());
  return summary;
}

}  // namespace relight
