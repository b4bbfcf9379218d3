#include "relight/relight.h"

#include <OpenImageIO/imageio.h>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "geometry/mesh_io.h"
#include "geometry/reconstruction.h"
#include "image/color.h"
#include "image/image.h"
#include "relight/display.h"
#include "relight/gltf_export.h"
#include "relight/transport_render.h"
#include "relight/viewer_export.h"
#include "render/lighting.h"
#include "render/render_view.h"
#include "render/rng.h"
#include "sphere/envmap.h"
#include "sphere/octahedral.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

std::string Stem(const std::string& name) { return fs::path(name).stem().string(); }

// Random-stream families of the render kinds (independent noise per kind).
enum KindStream : uint64_t { kRerender = 1, kHeldout = 2, kNovel = 3, kTurntable = 4 };

// One image to make.
struct Job {
  RenderRecord record;
  std::shared_ptr<const Lighting> lighting;  // null for flat images
  bool background = true;
  uint64_t stream = 0;      // kind stream
  uint64_t view_index = 0;  // index within the kind
  bool flat = false;        // per-vertex colours, no lighting
  std::vector<Eigen::Vector3f> flat_rgb;
  bool shared_exposure = false;  // turntable: exposure of the first frame
};

// A uniform environment of radiance `value` (all directions).
EnvMap UniformEnv(double value) {
  Image image(8, 4, 3, static_cast<float>(value));
  return EnvMap::FromLatLong(image);
}

std::shared_ptr<const Lighting> EnvLighting(EnvMap env) {
  return std::make_shared<const Lighting>(Lighting::FromEnvMap(std::move(env)));
}

// Delta light plus an optional uniform sky of ambient_fraction * E / pi (E = 1 at the object's centre).
Lighting DeltaLighting(double ambient_fraction) {
  Lighting l;
  if (ambient_fraction > 0) {
    EnvMap env = UniformEnv(ambient_fraction / M_PI);
    env.PrepareSampling();
    l.env = std::make_shared<const EnvMap>(std::move(env));
  }
  return l;
}

bool Exists(const std::string& path) { return !path.empty() && fs::is_regular_file(path); }

// Writes the frames (RGB in [0, 1]) as an animated GIF with OpenImageIO (atomic). Returns false when the
// GIF writer is unavailable.
bool WriteAnimatedGif(const std::string& path, const std::vector<Image>& frames, double fps) {
  if (frames.empty()) return false;
  auto out = OIIO::ImageOutput::create(path);
  if (!out || !out->supports("multiimage") || !out->supports("appendsubimage")) return false;
  AtomicFile file(path);
  const int w = frames[0].width, h = frames[0].height;
  OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
  const int rate[2] = {static_cast<int>(std::lround(fps * 100)), 100};
  spec.attribute("FramesPerSecond", OIIO::TypeRational, rate);
  spec.attribute("oiio:Movie", 1);
  spec.attribute("oiio:LoopCount", 0);
  std::vector<OIIO::ImageSpec> specs(frames.size(), spec);
  if (!out->open(file.temp_path(), static_cast<int>(specs.size()), specs.data())) {
    RELIGHT_USER_ERROR() << "cannot write '" << path << "': " << out->geterror();
  }
  std::vector<uint8_t> bytes(size_t(w) * h * 3);
  for (size_t k = 0; k < frames.size(); ++k) {
    RELIGHT_CHECK(frames[k].width == w && frames[k].height == h && frames[k].channels == 3);
    for (size_t p = 0; p < bytes.size(); ++p)
      bytes[p] = static_cast<uint8_t>(std::lround(255 * std::clamp(frames[k].pixels[p], 0.0f, 1.0f)));
    if (k > 0 && !out->open(file.temp_path(), specs[k], OIIO::ImageOutput::AppendSubimage)) {
      RELIGHT_USER_ERROR() << "cannot append frame " << k << " to '" << path << "': " << out->geterror();
    }
    if (!out->write_image(OIIO::TypeDesc::UINT8, bytes.data())) {
      RELIGHT_USER_ERROR() << "cannot write frame " << k << " of '" << path << "': " << out->geterror();
    }
  }
  out->close();
  file.Commit();
  return true;
}

// Each photo's recovered map from <inverse>/lighting.json (unseen texels zeroed when relight.zero_unseen_light)
// with its camera from <sfm>/sparse. Both files are required for re-renderings; without them the export gets
// no maps or no cameras, with a note.
std::vector<RecoveredPhoto> LoadRecoveredPhotos(const RelightOptions& o, const RelightInputs& in, const Scene& scene,
                                                std::vector<std::string>* notes) {
  const std::string lighting_path = JoinPath(in.inverse_dir, "lighting.json");
  const std::string sparse = JoinPath(in.sfm_dir, "sparse");
  const bool have_lighting = fs::is_regular_file(lighting_path);
  const bool have_cameras = !in.sfm_dir.empty() && fs::is_directory(sparse);
  if (o.rerender && !have_lighting) {
    RELIGHT_USER_ERROR() << "'" << lighting_path << "' is missing; rerun the inverse stage";
  }
  if (o.rerender && !have_cameras) {
    RELIGHT_USER_ERROR() << "relight.rerender needs the photos' cameras, but '" << sparse
                         << "' is missing; run the sfm stage (or set relight.rerender: false)";
  }
  if (!have_lighting) {
    notes->push_back("no environment maps exported: '" + lighting_path + "' is missing");
    return {};
  }
  if (!have_cameras) notes->push_back("export without cameras: '" + sparse + "' is missing");
  const Reconstruction cameras = have_cameras ? Reconstruction::Read(sparse) : Reconstruction();
  const Json lighting = ReadJsonFile(lighting_path);
  std::map<int, std::vector<char>> unseen_by_size;  // per map size
  std::vector<RecoveredPhoto> photos;
  for (const auto& p : lighting.at("photos")) {
    RecoveredPhoto photo;
    photo.name = p.at("name").get<std::string>();
    if (const ImageRecord* image = cameras.FindImage(photo.name)) {
      photo.camera = RenderCamera{photo.name, cameras.cameras.at(image->camera_id), *image};
    } else if (have_cameras) {
      notes->push_back("photo '" + photo.name + "' has a recovered map but no camera in " + sparse);
    }
    const std::string oct = JoinPath(in.inverse_dir, p.at("envmap_oct").get<std::string>());
    if (!fs::is_regular_file(oct)) RELIGHT_USER_ERROR() << "'" << oct << "' is missing; rerun the inverse stage";
    Image map = ReadImage(oct);
    Image sky;
    photo.sun = SolvedSun(p, map, &sky);
    if (o.zero_unseen_light) {
      auto it = unseen_by_size.find(map.width);
      if (it == unseen_by_size.end()) it = unseen_by_size.emplace(map.width, UnseenOctTexels(scene, map.width)).first;
      if (photo.sun) {
        const Eigen::Vector2i t = OctTexelOf(photo.sun->dir_world, map.width);
        if (it->second[size_t(t.y()) * map.width + t.x()]) photo.sun.reset();  // a sun no vertex sees: unseen light
      }
      map = ZeroTexels(map, it->second);
      if (photo.sun) sky = ZeroTexels(sky, it->second);
    }
    photo.envmap = EnvMap::FromOctahedral(map);
    if (photo.sun) photo.sky = EnvMap::FromOctahedral(sky);
    photos.push_back(std::move(photo));
  }
  return photos;
}

}  // namespace

RecoveredModel LoadRecoveredModel(const std::string& inverse_dir, const std::string& mesh_dir) {
  RecoveredModel model;
  const std::string ply = JoinPath(inverse_dir, "reflectance.ply");
  const std::string materials = JoinPath(inverse_dir, "materials.json");
  for (const std::string& path : {ply, materials}) {
    if (!fs::is_regular_file(path)) {
      RELIGHT_USER_ERROR() << "the inverse stage's output '" << path
                           << "' is missing; rerun the inverse stage (pipeline run CONFIG --from inverse)";
    }
  }
  model.mesh = ReadMesh(ply);
  if (model.mesh.empty()) RELIGHT_USER_ERROR() << "'" << ply << "' holds no triangles; rerun the inverse stage";
  if (model.mesh.normals.size() != model.mesh.num_vertices()) model.mesh.ComputeVertexNormals();
  model.reflectance = ReadReflectanceModel(materials);
  if (model.reflectance.materials.empty() || model.reflectance.basis.empty()) {
    RELIGHT_USER_ERROR() << "'" << materials << "' has no materials or no basis BRDFs; rerun the inverse stage";
  }
  const std::string occluders = mesh_dir.empty() ? "" : JoinPath(mesh_dir, "occluders.ply");
  if (Exists(occluders)) {
    model.occluders = ReadMesh(occluders);
    model.occluders.properties.clear();  // their reflectance is not recovered: grey Lambertian
    model.occluders.colors.clear();
    if (model.occluders.normals.size() != model.occluders.num_vertices()) model.occluders.ComputeVertexNormals();
  }
  MeshBoundingSphere(model.mesh, &model.center, &model.radius);
  if (const std::string path = JoinPath(inverse_dir, "lighting.json"); fs::is_regular_file(path)) {
    const Json lighting = ReadJsonFile(path);
    if (lighting.contains("env_resolution")) model.env_resolution = lighting.at("env_resolution").get<int>();
    if (lighting.contains("interreflection")) {
      const Json& bounce = lighting.at("interreflection");
      if (!bounce.is_object() || !bounce.contains("rays_per_side") || !bounce.at("rays_per_side").is_number_integer() ||
          bounce.at("rays_per_side").get<int>() < 1) {
        RELIGHT_USER_ERROR() << "'" << path << "': \"interreflection\" must be {\"rays_per_side\": k} with k >= 1; "
                             << "rerun the inverse stage";
      }
      model.bounce_rays_per_side = bounce.at("rays_per_side").get<int>();
      if (bounce.contains("occluder_albedo")) {
        const Json& a = bounce.at("occluder_albedo");
        if (!a.is_array() || a.size() != 3 || !a[0].is_number() || !a[1].is_number() || !a[2].is_number() ||
            a[0].get<double>() < 0 || a[1].get<double>() < 0 || a[2].get<double>() < 0) {
          RELIGHT_USER_ERROR() << "'" << path << "': \"interreflection\".\"occluder_albedo\" must be three "
                               << "non-negative numbers; rerun the inverse stage";
        }
        model.occluder_albedo = {a[0].get<double>(), a[1].get<double>(), a[2].get<double>()};
      }
    }
  }
  return model;
}

void EnableModelInterreflection(const RecoveredModel& model, TransportRenderer* transport, RenderOptions* monte_carlo) {
  if (model.bounce_rays_per_side <= 0) return;
  if (transport != nullptr) {
    BounceOptions bounce;
    bounce.rays_per_side = model.bounce_rays_per_side;
    const bool occluders_bounce = model.occluder_albedo.minCoeff() >= 0;
    const InterreflectionSummary is = transport->EnableInterreflection(bounce, occluders_bounce);
    RLOG_INFO(
        "interreflection on (the inverse stage solved with it): one bounce between the object's vertices{}, "
        "{}² rays per vertex, {} vertex pairs in {:.1f} s",
        occluders_bounce ? " and from the occluders" : "", bounce.rays_per_side, is.num_samples, is.seconds);
  }
  if (monte_carlo != nullptr) {
    if (monte_carlo->brdf_samples < 1) {
      RELIGHT_USER_ERROR() << "the inverse stage solved with interreflection, which the Monte Carlo renderer "
                           << "follows along BRDF samples: render with brdf_samples >= 1";
    }
    monte_carlo->interreflection = true;
    monte_carlo->bounce_from_occluders = model.occluder_albedo.minCoeff() >= 0;
  }
}

std::vector<Scene::Surface> ModelSurfaces(const TriangleMesh& object_mesh, const ReflectanceModel& reflectance,
                                          const TriangleMesh& occluders, const Eigen::Vector3d& occluder_albedo) {
  std::vector<Scene::Surface> surfaces;
  surfaces.push_back({object_mesh, reflectance, SurfaceRole::kObject});
  if (!occluders.empty())
    surfaces.push_back({occluders, LambertianModel(occluder_albedo, "occluder"), SurfaceRole::kOccluder});
  return surfaces;
}

std::optional<DirectionalLight> SolvedSun(const Json& entry, const Image& oct, Image* sky) {
  if (!entry.contains("sun") || !entry["sun"].contains("irradiance_rgb") || oct.width != oct.height ||
      oct.channels < 3 || oct.width <= 0) {
    return std::nullopt;
  }
  const auto d = entry["sun"].at("direction_world").get<std::vector<double>>();
  const auto e = entry["sun"].at("irradiance_rgb").get<std::vector<double>>();
  if (d.size() != 3 || e.size() != 3) return std::nullopt;
  const Eigen::Vector3d dir(d[0], d[1], d[2]);
  if (!(dir.norm() > 0) || !(std::min({e[0], e[1], e[2]}) >= 0)) return std::nullopt;
  const int n = oct.width;
  const Eigen::Vector2i t = OctTexelOf(dir, n);
  const double omega = OctTexelSolidAngle(t.x(), t.y(), n);
  *sky = oct;
  for (int c = 0; c < 3; ++c)
    sky->at(t.x(), t.y(), c) = std::max(0.0f, static_cast<float>(oct.at(t.x(), t.y(), c) - e[c] / omega));
  return DirectionalLight{dir.normalized(), Eigen::Vector3d(e[0], e[1], e[2])};
}

std::vector<char> UnseenOctTexels(const Scene& scene, int n, int max_vertices) {
  RELIGHT_CHECK(IsPowerOfTwo(n));
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> points;  // position, normal
  for (int s = 0; s < scene.num_surfaces(); ++s) {
    if (scene.surface(s).role != SurfaceRole::kObject) continue;
    const TriangleMesh& mesh = scene.surface(s).mesh;
    const size_t stride = std::max<size_t>(1, (mesh.num_vertices() + max_vertices - 1) / std::max(1, max_vertices));
    for (size_t v = 0; v < mesh.num_vertices(); v += stride)
      points.emplace_back(mesh.vertices[v].cast<double>(), mesh.normals[v].cast<double>());
  }
  const double eps = 1e-4 * scene.diagonal();
  // Where an object touches another surface (resting on the ground), offset ray origins end up behind it and
  // "see" through it: a texel counts as seen only from a few vertices at least.
  const int min_seen = std::max(2, int(std::lround(0.002 * points.size())));
  std::vector<char> seen(size_t(n) * n, 0);
  tbb::parallel_for(0, n * n, [&](int k) {
    const int i = k % n, j = k / n;
    static const double kOffsets[5][2] = {{0, 0}, {-0.35, -0.35}, {0.35, -0.35}, {-0.35, 0.35}, {0.35, 0.35}};
    std::vector<char> sees(points.size(), 0);
    int count = 0;
    for (const auto& o : kOffsets) {
      const Eigen::Vector3d d = OctDecode(Eigen::Vector2d((i + 0.5 + o[0]) / n, (j + 0.5 + o[1]) / n));
      for (size_t q = 0; q < points.size(); ++q) {
        if (sees[q]) continue;
        const auto& [p, normal] = points[q];
        // Two-sided surfaces: leave from the side facing the direction.
        Ray ray;
        ray.origin = (p + (normal.dot(d) >= 0 ? eps : -eps) * normal).cast<float>();
        ray.dir = d.cast<float>();
        if (!scene.caster().Occluded(ray)) {
          sees[q] = 1;
          if (++count >= min_seen) {
            seen[k] = 1;
            return;
          }
        }
      }
    }
  });
  std::vector<char> unseen(size_t(n) * n, 1);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      if (!seen[size_t(j) * n + i]) continue;
      for (int dj = -1; dj <= 1; ++dj)
        for (int di = -1; di <= 1; ++di) {
          // One step beyond the border: the neighbour on the sphere (fold rule).
          const Eigen::Vector2i t = OctWrapTexel(i + di, j + dj, n);
          unseen[size_t(t.y()) * n + t.x()] = 0;
        }
    }
  return unseen;
}

Image ZeroTexels(const Image& oct, const std::vector<char>& unseen) {
  RELIGHT_CHECK_EQ(size_t(oct.width) * oct.height, unseen.size());
  Image out = oct;
  for (int j = 0; j < oct.height; ++j)
    for (int i = 0; i < oct.width; ++i)
      if (unseen[size_t(j) * oct.width + i])
        for (int c = 0; c < oct.channels; ++c) out.at(i, j, c) = 0;
  return out;
}

Eigen::Vector3f MaterialColor(int m) {
  // Okabe-Ito colour-blind-safe palette (sRGB), linearised for the flat renders.
  static const float kSrgb[][3] = {{0.902f, 0.624f, 0.000f}, {0.337f, 0.706f, 0.914f}, {0.000f, 0.620f, 0.451f},
                                   {0.941f, 0.894f, 0.259f}, {0.000f, 0.447f, 0.698f}, {0.835f, 0.369f, 0.000f},
                                   {0.800f, 0.475f, 0.655f}, {0.600f, 0.600f, 0.600f}};
  const float* s = kSrgb[m % 8];
  Eigen::Vector3f linear;
  for (int c = 0; c < 3; ++c) linear[c] = static_cast<float>(SrgbDecode(s[c]));
  if (m >= 8) linear *= 0.5f;  // a second, darker round for more than 8 materials
  return linear;
}

std::vector<Eigen::Vector3f> DominantMaterialColors(const TriangleMesh& mesh, int num_materials) {
  std::vector<const std::vector<float>*> w;
  for (int m = 0; m < num_materials; ++m) w.push_back(mesh.FindProperty("w" + std::to_string(m)));
  std::vector<Eigen::Vector3f> rgb(mesh.num_vertices(), MaterialColor(0));
  for (size_t v = 0; v < mesh.num_vertices(); ++v) {
    int best = 0;
    float best_w = -1;
    for (int m = 0; m < num_materials; ++m) {
      const float x = w[m] ? (*w[m])[v] : (m == 0 ? 1.0f : 0.0f);
      if (x > best_w) {
        best_w = x;
        best = m;
      }
    }
    rgb[v] = MaterialColor(best);
  }
  return rgb;
}

std::string RelightSummary::BriefReport() const {
  std::map<std::string, int> per_kind;
  for (const auto& r : renders) ++per_kind[r.kind];
  std::ostringstream s;
  s << "relight: " << renders.size() << " images (";
  bool first = true;
  for (const auto& [kind, n] : per_kind) {
    s << (first ? "" : ", ") << n << " " << kind;
    first = false;
  }
  s << "); rendered " << rendered << ", reused " << reused << "; frame " << frame_method << "; ";
  if (!exported.model.empty()) {
    s << "export " << exported.model << " (" << exported.vertices << " vertices, " << exported.primitives
      << " primitives) and " << exported.envmaps.size() << " maps; ";
  }
  s << Progress::FormatSeconds(seconds);
  return s.str();
}

OrderedJson RelightSummary::ToJson() const {
  OrderedJson j;
  j["format"] = "relight-renders";
  j["version"] = 1;
  j["frame"] = frame_method;
  j["rendered"] = rendered;
  j["reused"] = reused;
  j["seconds"] = seconds;
  j["turntable_gif"] = turntable_gif;
  j["notes"] = notes;
  j["export"] = exported.ToJson();
  j["viewer"] = viewer;
  OrderedJson list = OrderedJson::array();
  for (const auto& r : renders) {
    OrderedJson e;
    e["kind"] = r.kind;
    e["name"] = r.name;
    e["view"] = r.view;
    e["light"] = r.light;
    e["exr"] = r.exr;
    e["png"] = r.png;
    e["mask"] = r.mask;
    e["exposure"] = r.exposure;
    e["seconds"] = r.seconds;
    e["camera"] = CameraToJson(r.camera.camera, r.camera.pose);
    list.push_back(e);
  }
  j["renders"] = list;
  return j;
}

std::vector<RenderRecord> ReadRenderIndex(const std::string& relight_dir, std::string* turntable_gif,
                                          ExportRecord* exported) {
  const std::string path = JoinPath(relight_dir, "relight_summary.json");
  if (!fs::is_regular_file(path)) {
    RELIGHT_USER_ERROR() << "'" << path << "' is missing; rerun the relight stage (pipeline run CONFIG --from relight)";
  }
  const Json j = ReadJsonFile(path);
  if (j.value("format", "") != "relight-renders" || j.value("version", 0) != 1) {
    RELIGHT_USER_ERROR() << "'" << path << "' is not a version-1 relight render index; rerun the relight stage";
  }
  std::vector<RenderRecord> out;
  for (const auto& e : j.at("renders")) {
    RenderRecord r;
    r.kind = e.value("kind", "");
    r.name = e.value("name", "");
    r.view = e.value("view", "");
    r.light = e.value("light", "");
    r.exr = e.value("exr", "");
    r.png = e.value("png", "");
    r.mask = e.value("mask", "");
    r.exposure = e.value("exposure", 1.0);
    r.seconds = e.value("seconds", 0.0);
    r.camera = CameraFromJson(e.at("camera"), path);
    r.camera.name = r.view;
    out.push_back(std::move(r));
  }
  if (turntable_gif != nullptr) *turntable_gif = j.value("turntable_gif", "");
  if (exported != nullptr) *exported = ExportRecord::FromJson(j.contains("export") ? j["export"] : Json());
  return out;
}

std::vector<EnvMap> LoadRelightEnvmaps(const std::vector<std::string>& paths) {
  std::vector<EnvMap> maps;
  for (const auto& path : paths) {
    std::error_code ec;
    if (fs::is_directory(path, ec)) {
      RELIGHT_USER_ERROR() << "relight.envmaps: '" << path << "' is a folder; list the map files in it (.exr/.hdr), "
                           << "one entry each";
    }
    if (!fs::is_regular_file(path, ec)) {
      const bool blender = path.rfind("/usr/share/blender/", 0) == 0;
      RELIGHT_USER_ERROR() << "relight.envmaps: '" << path << "' does not exist; "
                           << (blender ? "install Debian's blender-data (tools/setup_debian.sh) or list other maps"
                                       : "fix the path (relative to the config file) or remove the entry");
    }
    try {
      maps.push_back(EnvMap::Load(path));
    } catch (const UserError& e) {
      throw UserError(std::string("relight.envmaps: ") + e.what() + "; or remove the entry from relight.envmaps");
    }
  }
  return maps;
}

namespace {

// The relight.envmaps maps as named lights (file stems, made unique with _2, _3, ...), in their order.
using NamedLights = std::vector<std::pair<std::string, std::shared_ptr<const Lighting>>>;

// What the rendering steps share.
struct RelightContext {
  const RelightOptions& options;
  const std::string& output_dir;
  const ShardSpec& shard;
  const RecoveredModel& model;
  const Scene& scene;  // the model's surfaces, as rendered
};

// Appends `job` with its file names (renders/<kind>/<name>{.exr,.png,_mask.png}; no EXR for flat images).
void AddJob(Job job, std::vector<Job>* jobs) {
  const std::string dir = "renders/" + job.record.kind + "/";
  if (!job.flat) job.record.exr = dir + job.record.name + ".exr";
  job.record.png = dir + job.record.name + ".png";
  job.record.mask = dir + job.record.name + "_mask.png";
  jobs->push_back(std::move(job));
}

// (a) Re-renderings of the input photos (those with a camera) under their recovered maps, at most
// relight.rerender_max_size pixels on the longer side.
void AddRerenderJobs(const RelightOptions& o, const std::vector<RecoveredPhoto>& photos, std::vector<Job>* jobs) {
  uint64_t index = 0;
  for (const RecoveredPhoto& photo : photos) {
    if (!photo.camera) continue;
    Job job;
    job.record.kind = "rerender";
    job.record.name = Stem(photo.name);
    job.record.view = photo.name;
    job.record.light = "recovered:" + Stem(photo.name);
    job.record.camera = *photo.camera;
    Camera& camera = job.record.camera.camera;
    const int longer = std::max(camera.width, camera.height);
    if (o.rerender_max_size > 0 && longer > o.rerender_max_size) {
      const double s = double(o.rerender_max_size) / longer;
      const int w = std::max(1, int(std::lround(camera.width * s))),
                h = std::max(1, int(std::lround(camera.height * s)));
      camera.Rescale(s);
      camera.width = w;
      camera.height = h;
    }
    if (photo.sun) {
      auto lighting = std::make_shared<Lighting>(Lighting::FromEnvMap(photo.sky));
      lighting->directional.push_back(*photo.sun);
      job.lighting = std::move(lighting);
    } else {
      job.lighting = EnvLighting(photo.envmap);
    }
    job.background = o.background;
    job.stream = kRerender;
    job.view_index = index++;
    AddJob(std::move(job), jobs);
  }
}

// (b) The given held-out views under their maps (already in the model's frame); records the frame relation (or
// why there are none) in `summary`.
void AddHeldoutJobs(const RelightOptions& o, const HeldoutViews& heldout, std::vector<Job>* jobs,
                    RelightSummary* summary) {
  summary->frame_method = heldout.frame_method;
  for (const auto& note : heldout.notes) summary->notes.push_back(note);
  if (!o.heldout) return;
  std::map<std::string, std::shared_ptr<const Lighting>> envs;
  for (const auto& [name, env] : heldout.envmaps) envs[name] = EnvLighting(env);
  uint64_t k = 0;
  for (const auto& [view, env] : heldout.renders) {
    const ImageRecord* image = heldout.cameras.FindImage(view);
    RELIGHT_CHECK(image != nullptr && envs.count(env))
        << "held-out view '" << view << "' or map '" << env << "' is not among the given cameras and maps";
    Job job;
    job.record.kind = "heldout";
    job.record.name = view + "__" + env;
    job.record.view = view;
    job.record.light = "heldout:" + env;
    job.record.camera = {view, heldout.cameras.cameras.at(image->camera_id), *image};
    job.lighting = envs[env];
    job.background = true;
    job.stream = kHeldout;
    job.view_index = k++;
    AddJob(std::move(job), jobs);
  }
}

// The relight.envmaps maps named by their file stems (a repeated stem gets _2, _3, ...).
NamedLights FileLights(const std::vector<std::string>& paths, const std::vector<EnvMap>& file_maps) {
  NamedLights file_lights;
  std::set<std::string> used;
  for (size_t m = 0; m < paths.size(); ++m) {
    const std::string& path = paths[m];
    std::string name = Stem(path);
    for (int k = 2; used.count(name); ++k) name = Stem(path) + "_" + std::to_string(k);
    used.insert(name);
    file_lights.emplace_back(name, EnvLighting(file_maps[m]));
  }
  return file_lights;
}

// The directional light of the new views (relight.directional_*) plus the dim uniform sky.
std::shared_ptr<const Lighting> DirectionalLighting(const RelightOptions& o) {
  Lighting l = DeltaLighting(o.ambient_fraction);
  const double az = (o.view_azimuth_deg + o.directional_azimuth_deg) * M_PI / 180;
  const double el = o.directional_elevation_deg * M_PI / 180;
  l.directional.push_back({Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)),
                           Eigen::Vector3d::Ones()});
  return std::make_shared<const Lighting>(std::move(l));
}

// A point light above and beside camera `view` plus the dim uniform sky.
std::shared_ptr<const Lighting> PointLighting(const RelightOptions& o, const RecoveredModel& model,
                                              const RenderCamera& view) {
  Lighting l = DeltaLighting(o.ambient_fraction);
  const Eigen::Vector3d c = view.pose.ProjectionCenter();
  const double d = (c - model.center).norm();
  const Eigen::Vector3d right = view.pose.CamFromWorldRotation().row(0).transpose();
  const Eigen::Vector3d position = c + 0.35 * d * right + 0.35 * d * Eigen::Vector3d::UnitZ();
  // Irradiance 1 on a surface at the object's centre facing the light.
  const double r2 = (position - model.center).squaredNorm();
  l.points.push_back({position, Eigen::Vector3d::Constant(r2)});
  return std::make_shared<const Lighting>(std::move(l));
}

// A flat image of per-vertex colours `rgb` (no lighting) from camera `view`.
Job FlatJob(const std::string& kind, const RenderCamera& view, std::vector<Eigen::Vector3f> rgb) {
  Job job;
  job.record.kind = kind;
  job.record.name = view.name;
  job.record.view = view.name;
  job.record.light = "none";
  job.record.camera = view;
  job.flat = true;
  job.flat_rgb = std::move(rgb);
  return job;
}

// (c) New orbit views under the new lights (the file maps, a directional and a point light), and flat albedo
// and dominant-material images from them.
void AddNovelJobs(const RelightOptions& o, const RecoveredModel& model, const NamedLights& file_lights,
                  std::vector<Job>* jobs) {
  std::vector<RenderCamera> orbit;
  for (int v = 0; v < o.views; ++v) {
    orbit.push_back(OrbitCamera("view_" + std::to_string(v), model.center, model.radius,
                                o.view_azimuth_deg + 360.0 * v / o.views, o.view_elevation_deg, o.image_size, o.fov_deg,
                                o.fill));
  }
  uint64_t novel_index = 0;
  for (const RenderCamera& view : orbit) {
    auto add_novel = [&](const std::string& light_name, const std::string& light, std::shared_ptr<const Lighting> l) {
      Job job;
      job.record.kind = "novel";
      job.record.name = view.name + "__" + light_name;
      job.record.view = view.name;
      job.record.light = light;
      job.record.camera = view;
      job.lighting = std::move(l);
      job.background = o.background;
      job.stream = kNovel;
      job.view_index = novel_index++;
      AddJob(std::move(job), jobs);
    };
    for (const auto& [name, l] : file_lights) add_novel(name, "envmap:" + name, l);
    if (o.directional_light) add_novel("directional", "directional", DirectionalLighting(o));
    if (o.point_light) add_novel("point", "point", PointLighting(o, model, view));
    const std::vector<float>* ar = model.mesh.FindProperty("albedo_r");
    const std::vector<float>* ag = model.mesh.FindProperty("albedo_g");
    const std::vector<float>* ab = model.mesh.FindProperty("albedo_b");
    if (ar && ag && ab) {
      std::vector<Eigen::Vector3f> albedo;
      for (size_t v = 0; v < model.mesh.num_vertices(); ++v) albedo.emplace_back((*ar)[v], (*ag)[v], (*ab)[v]);
      AddJob(FlatJob("albedo", view, std::move(albedo)), jobs);
    }
    AddJob(FlatJob("material", view, DominantMaterialColors(model.mesh, int(model.reflectance.materials.size()))),
           jobs);
  }
}

// (d) The turntable's frames, on an orbit under relight.turntable_light (or a note in `summary` when there is no
// map to light it with).
void AddTurntableJobs(const RelightOptions& o, const RecoveredModel& model, const NamedLights& file_lights,
                      std::vector<Job>* jobs, RelightSummary* summary) {
  std::shared_ptr<const Lighting> light;
  std::string light_name;
  if (o.turntable_light == "first_envmap" && !file_lights.empty()) {
    light = file_lights[0].second;
    light_name = "envmap:" + file_lights[0].first;
  } else {
    for (const auto& j : *jobs)
      if (j.record.kind == "rerender") {
        light = j.lighting;
        light_name = j.record.light;
        break;
      }
  }
  if (!light) {
    summary->notes.push_back(
        "no turntable: no environment map (relight.envmaps is empty and no photo was re-rendered)");
    return;
  }
  for (int f = 0; f < o.turntable_frames; ++f) {
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%03d", f);
    Job job;
    job.record.kind = "turntable";
    job.record.name = name;
    job.record.view = name;
    job.record.light = light_name;
    job.record.camera =
        OrbitCamera(name, model.center, model.radius, o.view_azimuth_deg + 360.0 * f / o.turntable_frames,
                    o.view_elevation_deg, o.turntable_size, o.fov_deg, o.fill);
    job.lighting = light;
    job.background = o.background;
    job.stream = kTurntable;
    job.view_index = uint64_t(f);
    job.shared_exposure = true;
    AddJob(std::move(job), jobs);
  }
}

// The visibility stage's maps (transport renderer and viewer).
struct VisibilityMaps {
  std::string path;        // <visibility>/visibility.bin; empty without the stage
  bool available = false;  // the file exists (and `data` holds it)
  VisibilityData data;
};

// Reads <visibility_dir>/visibility.bin when it exists.
VisibilityMaps LoadVisibilityMaps(const std::string& visibility_dir) {
  VisibilityMaps maps;
  maps.path = visibility_dir.empty() ? "" : JoinPath(visibility_dir, "visibility.bin");
  maps.available = !maps.path.empty() && fs::is_regular_file(maps.path);
  if (maps.available) maps.data = ReadVisibility(maps.path);
  return maps;
}

// The interactive viewer (relight/viewer_export.h), under each photo's recovered map and each new map, its diffuse
// rows `transport`'s; its page's path in `page`.
void WriteViewer(const RelightContext& ctx, const std::vector<RecoveredPhoto>& photos, const NamedLights& file_lights,
                 const std::vector<EnvMap>& file_maps, const VisibilityMaps& visibility,
                 const TransportRenderer& transport, std::string* page) {
  std::vector<std::pair<std::string, EnvMap>> maps;
  for (const RecoveredPhoto& photo : photos) maps.emplace_back(Stem(photo.name), photo.envmap);
  for (size_t m = 0; m < file_lights.size(); ++m) maps.emplace_back(file_lights[m].first, file_maps[m]);
  ViewerOptions vo;
  vo.env_resolution = ctx.model.env_resolution;
  vo.tonemap_percentile = ctx.options.tonemap_percentile;
  const ViewerExport viewer =
      WriteViewerAssets(JoinPath(ctx.output_dir, "export/viewer"), ctx.model, visibility.data, transport, maps, vo);
  *page = "export/viewer/viewer.html";
  RLOG_INFO("viewer: {}", viewer.BriefReport());
}

// A rendered view's radiance and mask are its result; its PNG is written from them when missing.
bool JobDone(const Job& job, const std::string& output_dir) {
  return (job.flat || Exists(JoinPath(output_dir, job.record.exr))) && Exists(JoinPath(output_dir, job.record.mask));
}

// A shard renders the radiance of its own views (every shard-th job); the whole run that follows writes
// every PNG, so a shared exposure (turntable) is the same as in one run.
bool JobSkipped(const std::vector<Job>& jobs, size_t k, const ShardSpec& shard) {
  return shard.active() && (jobs[k].flat || !shard.Owns(k));
}

// The renderer of the jobs still to render: the transport renderer or the Monte Carlo options.
struct JobRenderer {
  RenderOptions monte_carlo;                     // relight's samples; interreflection as the model was solved
  TransportRenderOptions transport_options;      // relight's pixel samples
  std::unique_ptr<TransportRenderer> transport;  // null: render with `monte_carlo`
  std::map<const Lighting*, size_t> last_use;    // the last job of each light in the render order (its cache)
  int64_t tiles = 0;                             // work units of the jobs to render (progress)
};

// Sets up the renderer of the jobs that are neither done nor another shard's (relight.renderer).
JobRenderer PrepareRenderer(const RelightContext& ctx, const VisibilityMaps& visibility, const std::vector<Job>& jobs,
                            const std::vector<size_t>& order) {
  const RelightOptions& o = ctx.options;
  const RecoveredModel& model = ctx.model;
  JobRenderer renderer;
  RenderOptions& base = renderer.monte_carlo;
  base.pixel_samples_per_axis = o.pixel_samples_per_axis;
  base.light_samples = o.light_samples;
  base.brdf_samples = o.brdf_samples;
  renderer.transport_options.pixel_samples_per_axis = o.pixel_samples_per_axis;
  const bool use_transport = o.renderer == "transport";
  // The last job of each light: what the transport renderer keeps for it is dropped after it.
  for (size_t k : order) {
    const Job& job = jobs[k];
    if (job.flat || JobDone(job, ctx.output_dir) || JobSkipped(jobs, k, ctx.shard)) continue;
    renderer.tiles += use_transport ? TransportRenderer::NumBands(job.record.camera.camera, renderer.transport_options)
                                    : NumTiles(job.record.camera.camera, base);
    renderer.last_use[job.lighting.get()] = k;
  }
  if (use_transport && renderer.tiles > 0) {
    if (!visibility.available) {
      RELIGHT_USER_ERROR() << "relight.renderer: transport needs the visibility stage's maps"
                           << (visibility.path.empty() ? "" : " ('" + visibility.path + "' is missing)")
                           << "; run the visibility stage (or set relight.renderer: monte_carlo)";
    }
    renderer.transport = std::make_unique<TransportRenderer>(ctx.scene, visibility.data, model.env_resolution);
    RLOG_INFO("transport renderer: {}x{} visibility maps, light filtered to {}x{} octahedral texels",
              visibility.data.resolution, visibility.data.resolution, model.env_resolution, model.env_resolution);
  }
  if (renderer.tiles > 0) {
    EnableModelInterreflection(model, renderer.transport.get(), renderer.transport ? nullptr : &base);
    if (!renderer.transport && base.interreflection)
      RLOG_INFO("interreflection on (the inverse stage solved with it): the Monte Carlo renderer adds one bounce");
  }
  return renderer;
}

// Job `k`'s radiance and mask, rendered.
RenderedView RenderJob(const RelightContext& ctx, size_t k, const Job& job, JobRenderer* renderer, Progress* progress) {
  const RelightOptions& o = ctx.options;
  const RenderRecord& r = job.record;
  if (renderer->transport) {
    TransportRenderOptions to = renderer->transport_options;
    to.background = job.background;
    RenderedView view = renderer->transport->Render(*job.lighting, r.camera.camera, r.camera.pose, to, progress);
    if (renderer->last_use[job.lighting.get()] == k) renderer->transport->Forget(*job.lighting);
    return view;
  }
  RenderOptions ro = renderer->monte_carlo;
  if (r.kind == "heldout" || r.kind == "rerender") {  // scored by evaluate
    ro.light_samples = std::max(ro.light_samples, o.scored_samples);
    ro.brdf_samples = std::max(ro.brdf_samples, o.scored_samples);
  }
  ro.background = job.background;
  ro.seed = MixSeed(uint64_t(o.seed), job.stream);
  return RenderView(ctx.scene, *job.lighting, r.camera.camera, r.camera.pose, ro, job.view_index, progress);
}

// Writes flat image `r` (per-vertex colours `rgb`) and its mask.
void WriteFlatImage(const RelightContext& ctx, const std::vector<Eigen::Vector3f>& rgb, RenderRecord* r) {
  Image mask;
  const Image image = RenderVertexColors(ctx.scene.caster(), 0, rgb, r->camera.camera, r->camera.pose,
                                         Eigen::Vector3f::Constant(0.18f), &mask);
  // Albedo is shown as is (1 = white) unless it exceeds 1 (gauge), then like a render.
  r->exposure = r->kind == "albedo" ? std::min(1.0, PercentileExposure(image, &mask, 99.5)) : 1.0;
  WritePng(JoinPath(ctx.output_dir, r->mask), mask);
  WritePng(JoinPath(ctx.output_dir, r->png), ToneMapSrgb(image, r->exposure));
}

// Tasks that write files while the views render (the renderers keep both cores busy, encoding an image is serial).
// Waited for before the summary is written, and when an exception leaves the stage early, so that no task outlives
// what it reads; the first task's exception is rethrown by Wait.
class BackgroundWrites {
 public:
  ~BackgroundWrites() {
    if (!waited_) {
      group_.cancel();
      try {
        group_.wait();
      } catch (...) {  // the exception already leaving the stage is the one to report
      }
    }
  }
  template <typename F>
  void Run(F&& f) {
    group_.run(std::forward<F>(f));
  }
  void Wait() {
    waited_ = true;
    group_.wait();
  }

 private:
  tbb::task_group group_;
  bool waited_ = false;
};

// The order the jobs render in: the turntable first, so that its animation is encoded while the other views
// render, then the others as listed (their random streams do not depend on the order).
std::vector<size_t> RenderOrder(const std::vector<Job>& jobs) {
  std::vector<size_t> order;
  for (size_t k = 0; k < jobs.size(); ++k)
    if (jobs[k].record.kind == "turntable") order.push_back(k);
  for (size_t k = 0; k < jobs.size(); ++k)
    if (jobs[k].record.kind != "turntable") order.push_back(k);
  return order;
}

// Renders what is missing (a shard: only the radiance and masks of its views) in `order`, reads back what an
// earlier run rendered, and writes the PNGs and the turntable's animated GIF (renders/turntable/turntable.gif,
// in summary->turntable_gif unless OpenImageIO cannot write one) in `background`; counts both in `summary`.
void RenderJobs(const RelightContext& ctx, JobRenderer* renderer, const std::vector<size_t>& order,
                std::vector<Job>* jobs, RelightSummary* summary, BackgroundWrites* background) {
  const RelightOptions& o = ctx.options;
  for (const auto& dir : {"rerender", "heldout", "novel", "albedo", "material", "turntable"})
    EnsureDir(JoinPath(ctx.output_dir, std::string("renders/") + dir));
  double turntable_exposure = -1;
  size_t turntable_left = 0;
  for (const Job& job : *jobs) turntable_left += job.record.kind == "turntable";
  std::vector<Image> turntable_frames;  // displayed (sRGB), for the animation
  Progress progress("relight renders", std::max<int64_t>(renderer->tiles, 1));
  for (size_t k : order) {
    if (JobSkipped(*jobs, k, ctx.shard)) continue;
    Job& job = (*jobs)[k];
    RenderRecord& r = job.record;
    const std::string exr = JoinPath(ctx.output_dir, r.exr), png = JoinPath(ctx.output_dir, r.png),
                      mask_path = JoinPath(ctx.output_dir, r.mask);
    if (job.flat) {
      WriteFlatImage(ctx, job.flat_rgb, &r);
      continue;
    }
    Image radiance, mask;
    if (JobDone(job, ctx.output_dir)) {
      radiance = ReadImage(exr);
      mask = ReadMask(mask_path);
      ++summary->reused;
    } else {
      const RenderedView view = RenderJob(ctx, k, job, renderer, &progress);
      radiance = view.radiance;
      mask = view.mask;
      r.seconds = view.seconds;
      background->Run([exr, mask_path, radiance, mask] {
        WriteExr(exr, radiance);
        WritePng(mask_path, mask);
      });
      ++summary->rendered;
    }
    if (ctx.shard.active()) continue;
    double exposure = PercentileExposure(radiance, CountMask(mask) > 0 ? &mask : nullptr, o.tonemap_percentile);
    if (job.shared_exposure) {
      if (turntable_exposure < 0) turntable_exposure = exposure;
      exposure = turntable_exposure;
    }
    r.exposure = exposure;
    if (r.kind == "turntable") {
      turntable_frames.push_back(ToneMapSrgb(radiance, exposure));
      if (!Exists(png) || r.seconds > 0)
        background->Run([png, srgb = turntable_frames.back()] { WritePng(png, srgb); });
      if (--turntable_left == 0) {
        background->Run([&ctx, summary, frames = std::move(turntable_frames)] {
          const std::string gif = "renders/turntable/turntable.gif";
          if (WriteAnimatedGif(JoinPath(ctx.output_dir, gif), frames, ctx.options.turntable_fps))
            summary->turntable_gif = gif;
        });
      }
    } else if (!Exists(png) || r.seconds > 0) {
      background->Run(
          [png, radiance = std::move(radiance), exposure] { WritePng(png, ToneMapSrgb(radiance, exposure)); });
    }
    LogFileOnly(fmt::format("{}/{}: {}x{}, light {}, {:.2f} s", r.kind, r.name, r.camera.camera.width,
                            r.camera.camera.height, r.light, r.seconds));
  }
}

}  // namespace

RelightSummary RunRelight(const RelightOptions& o, const RelightInputs& in, const std::string& output_dir,
                          const ShardSpec& shard) {
  o.Check();
  Timer total;
  RelightSummary summary;
  // The new lights, read before any rendering: a bad entry fails the stage at once, naming it.
  const std::vector<EnvMap> file_maps = LoadRelightEnvmaps(o.envmaps);
  const RecoveredModel model = LoadRecoveredModel(in.inverse_dir, in.mesh_dir);
  const Scene scene(
      ModelSurfaces(model.mesh, model.reflectance, model.occluders, model.OccluderAlbedo(o.occluder_albedo)),
      JoinPath(in.inverse_dir, "reflectance.ply"));
  RLOG_INFO("model: {} vertices, {} materials over {} basis BRDFs, {} occluder vertices; bounding sphere r = {:.4g}",
            model.mesh.num_vertices(), model.reflectance.materials.size(), model.reflectance.basis.size(),
            model.occluders.num_vertices(), model.radius);
  const RelightContext ctx{o, output_dir, shard, model, scene};

  // The images to make, listed in this order (their random streams depend on it; RenderOrder renders them).
  std::vector<Job> jobs;
  // (a) Re-renderings of the input photos under their recovered maps (which the export writes too).
  const std::vector<RecoveredPhoto> photos = LoadRecoveredPhotos(o, in, scene, &summary.notes);
  if (o.rerender) AddRerenderJobs(o, photos, &jobs);
  // (b) Held-out views under held-out maps, in the model's frame.
  AddHeldoutJobs(o, in.heldout, &jobs, &summary);
  // (c) New orbit views under new lights, and flat albedo / material images.
  const NamedLights file_lights = FileLights(o.envmaps, file_maps);
  AddNovelJobs(o, model, file_lights, &jobs);
  // (d) Turntable.
  if (o.turntable_frames > 0) AddTurntableJobs(o, model, file_lights, &jobs, &summary);

  const VisibilityMaps visibility = LoadVisibilityMaps(in.visibility_dir);
  // The export for Blender and other tools (relight/gltf_export.h), rewritten on every whole run, the interactive
  // viewer and the images' files are written in background tasks (each sets its own fields of `summary`) while
  // the views render; what they read is declared before them, so that they end first.
  JobRenderer renderer;
  std::unique_ptr<TransportRenderer> viewer_rows;
  BackgroundWrites background;
  if (!shard.active()) {  // a shard renders only
    background.Run([&] {
      summary.exported = WriteExport(output_dir, model.mesh, model.reflectance, photos);
      RLOG_INFO("export: {} ({} vertices, {} triangles, {} primitives), {} environment maps, albedo scale {:.4g}",
                summary.exported.model, summary.exported.vertices, summary.exported.triangles,
                summary.exported.primitives, summary.exported.envmaps.size(), summary.exported.albedo_scale);
    });
  }
  const std::vector<size_t> order = RenderOrder(jobs);
  renderer = PrepareRenderer(ctx, visibility, jobs, order);
  // The viewer's diffuse rows and bounce are the transport renderer's (a renderer of their own when the views
  // render by Monte Carlo): the rows built first, on all threads, so that the viewer reads them while the views
  // render.
  const TransportRenderer* rows = nullptr;
  if (!shard.active() && visibility.available) {
    if (!renderer.transport) {
      viewer_rows = std::make_unique<TransportRenderer>(scene, visibility.data, model.env_resolution);
      EnableModelInterreflection(model, viewer_rows.get(), nullptr);
    }
    TransportRenderer* transport = renderer.transport ? renderer.transport.get() : viewer_rows.get();
    Timer rows_timer;
    transport->BuildObjectRows();
    RLOG_INFO("transport rows: {} vertices in {:.1f} s", model.mesh.num_vertices(), rows_timer.Seconds());
    rows = transport;
  }
  if (rows != nullptr)
    background.Run([&] { WriteViewer(ctx, photos, file_lights, file_maps, visibility, *rows, &summary.viewer); });
  if (!shard.active() && !visibility.available)
    summary.notes.push_back("no interactive viewer: the visibility stage's maps were not given");

  RenderJobs(ctx, &renderer, order, &jobs, &summary, &background);
  background.Wait();
  if (shard.active()) return summary;  // the whole run that follows writes the PNGs, animation and summary

  const bool turntable =
      std::any_of(jobs.begin(), jobs.end(), [](const Job& j) { return j.record.kind == "turntable"; });
  if (turntable && summary.turntable_gif.empty())
    summary.notes.push_back("OpenImageIO cannot write animated GIFs here: the turntable is its PNG frames only");
  for (auto& job : jobs) summary.renders.push_back(std::move(job.record));
  summary.seconds = total.Seconds();
  WriteJsonAtomic(JoinPath(output_dir, "relight_summary.json"), summary.ToJson());
  for (const auto& note : summary.notes) RLOG_INFO("note: {}", note);
  return summary;
}

}  // namespace relight
