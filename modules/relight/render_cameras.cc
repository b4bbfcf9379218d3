#include "relight/render_cameras.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "geometry/reconstruction.h"
#include "relight/display.h"
#include "relight/relight.h"
#include "relight/transport_render.h"
#include "render/render_view.h"
#include "visibility/visibility.h"

namespace relight {
namespace {
namespace fs = std::filesystem;
}  // namespace

EnvmapConvention ParseEnvmapConvention(const std::string& name) {
  if (name == "relight") return EnvmapConvention::kRelight;
  if (name == "blender") return EnvmapConvention::kBlender;
  if (name == "mitsuba") return EnvmapConvention::kMitsuba;
  RELIGHT_USER_ERROR() << "unknown environment map convention '" << name
                       << "'; use relight, blender or mitsuba (docs/FORMATS.md)";
}

std::string EnvmapConventionName(EnvmapConvention convention) {
  switch (convention) {
    case EnvmapConvention::kRelight:
      return "relight";
    case EnvmapConvention::kBlender:
      return "blender";
    case EnvmapConvention::kMitsuba:
      return "mitsuba";
  }
  return "relight";
}

Image LatLongToProjectConvention(const Image& latlong, EnvmapConvention from) {
  if (from == EnvmapConvention::kRelight) return latlong;
  const int w = latlong.width;
  // The tool's u of the direction at our column centre u = (col + 0.5)/W: u_tool = offset − u.
  const double offset = from == EnvmapConvention::kBlender ? 0.5 : 0.25;
  Image out(w, latlong.height, latlong.channels);
  for (int col = 0; col < w; ++col) {
    const double u_tool = offset - (col + 0.5) / w;
    double x = u_tool * w - 0.5;  // continuous source column
    x -= std::floor(x / w) * w;   // into [0, w)
    const int x0 = static_cast<int>(std::floor(x)) % w, x1 = (x0 + 1) % w;
    const float t = static_cast<float>(x - std::floor(x));
    for (int row = 0; row < latlong.height; ++row)
      for (int c = 0; c < latlong.channels; ++c)
        out.at(col, row, c) = (1 - t) * latlong.at(x0, row, c) + t * latlong.at(x1, row, c);
  }
  return out;
}

EnvMap LoadEnvmapInConvention(const std::string& path, EnvmapConvention convention, double rotate_deg,
                              double strength) {
  if (!fs::is_regular_file(path)) {
    RELIGHT_USER_ERROR() << "environment map '" << path << "' does not exist or is not a file";
  }
  if (!(strength >= 0) || !std::isfinite(strength)) {
    RELIGHT_USER_ERROR() << "the light's strength must be a finite number >= 0, not " << strength;
  }
  EnvMap map;
  const Image probe = ReadImage(path, nullptr, /*apply_orientation=*/false);
  if (probe.width == probe.height) {
    if (convention != EnvmapConvention::kRelight) {
      RELIGHT_USER_ERROR() << "'" << path << "' is square: an octahedral map, which exists in this project's "
                           << "convention only; pass --envmap-convention relight, or a lat-long (2:1) map";
    }
    for (float v : probe.pixels) {
      if (!std::isfinite(v) || v < 0) {
        RELIGHT_USER_ERROR() << "octahedral map '" << path << "' holds a NaN, infinite or negative value";
      }
    }
    if (probe.width < 2 || (probe.width & (probe.width - 1)) != 0) {
      RELIGHT_USER_ERROR() << "octahedral map '" << path << "' is " << probe.width << "x" << probe.height
                           << "; its side must be a power of two";
    }
    map = EnvMap::FromOctahedral(probe);
  } else {
    const EnvMap loaded = EnvMap::Load(path);  // checks 2:1 and finite values, clamps small negatives
    map = EnvMap::FromLatLong(LatLongToProjectConvention(loaded.image(), convention));
  }
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(rotate_deg * M_PI / 180, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return map.Transformed(turn, strength);
}

std::string RenderCamerasSummary::BriefReport() const {
  return fmt::format("{} images ({} convention) in {:.1f} s", images.size(), convention, seconds);
}

RenderCamerasSummary RenderCameras(const RenderCamerasRequest& r) {
  Timer total;
  RenderCamerasSummary summary;
  summary.convention = EnvmapConventionName(r.convention);
  if (r.renderer != "transport" && r.renderer != "monte_carlo") {
    RELIGHT_USER_ERROR() << "unknown renderer '" << r.renderer << "'; use transport or monte_carlo";
  }
  if (r.pixel_samples_per_axis < 1 || r.max_size < 0 || r.monte_carlo_samples < 1) {
    RELIGHT_USER_ERROR() << "pixel samples per axis and Monte Carlo samples must be >= 1, the size >= 0";
  }
  const Lighting lighting =
      Lighting::FromEnvMap(LoadEnvmapInConvention(r.envmap, r.convention, r.rotate_deg, r.strength));
  if (!fs::is_directory(r.cameras_dir)) {
    RELIGHT_USER_ERROR() << "camera model folder '" << r.cameras_dir
                         << "' does not exist; give a COLMAP model (cameras and images, .txt or .bin) in the model's "
                         << "frame, e.g. <workspace>/stages/sfm/sparse";
  }
  const Reconstruction cameras = Reconstruction::Read(r.cameras_dir);
  if (cameras.images.empty()) {
    RELIGHT_USER_ERROR() << "camera model '" << r.cameras_dir << "' holds no images (posed cameras) to render";
  }
  const RecoveredModel model = LoadRecoveredModel(r.inverse_dir, r.mesh_dir);
  const Scene scene(
      ModelSurfaces(model.mesh, model.reflectance, model.occluders, model.OccluderAlbedo(r.occluder_albedo)),
      JoinPath(r.inverse_dir, "reflectance.ply"));
  VisibilityData visibility;
  std::unique_ptr<TransportRenderer> transport;
  if (r.renderer == "transport") {
    const std::string path = JoinPath(r.visibility_dir, "visibility.bin");
    if (r.visibility_dir.empty() || !fs::is_regular_file(path)) {
      RELIGHT_USER_ERROR() << "the transport renderer needs the visibility stage's maps ('" << path
                           << "' is missing): run the visibility stage, or render with monte_carlo";
    }
    visibility = ReadVisibility(path);
    transport = std::make_unique<TransportRenderer>(scene, visibility, model.env_resolution);
  }
  EnsureDir(r.output_dir);
  std::vector<RenderCamera> views;
  for (const auto& [id, image] : cameras.images) {
    auto cam = cameras.cameras.find(image.camera_id);
    if (cam == cameras.cameras.end()) {
      RELIGHT_USER_ERROR() << "camera model '" << r.cameras_dir << "': image '" << image.name
                           << "' names camera " << image.camera_id << ", which it does not hold";
    }
    RenderCamera view{image.name, cam->second, image};
    const int longer = std::max(view.camera.width, view.camera.height);
    if (r.max_size > 0 && longer > r.max_size) {
      const double s = double(r.max_size) / longer;
      const int w = std::max(1, int(std::lround(view.camera.width * s))),
                h = std::max(1, int(std::lround(view.camera.height * s)));
      view.camera.Rescale(s);
      view.camera.width = w;
      view.camera.height = h;
    }
    views.push_back(view);
  }
  TransportRenderOptions to;
  to.pixel_samples_per_axis = r.pixel_samples_per_axis;
  to.background = r.background;
  RenderOptions mc;
  mc.pixel_samples_per_axis = r.pixel_samples_per_axis;
  mc.light_samples = r.monte_carlo_samples;
  mc.brdf_samples = r.monte_carlo_samples;
  mc.background = r.background;
  EnableModelInterreflection(model, transport.get(), &mc);
  int64_t units = 0;
  for (const RenderCamera& v : views)
    units += transport ? TransportRenderer::NumBands(v.camera, to) : NumTiles(v.camera, mc);
  Progress progress("render", std::max<int64_t>(units, 1));
  OrderedJson index = OrderedJson::array();
  for (size_t k = 0; k < views.size(); ++k) {
    const RenderCamera& v = views[k];
    const RenderedView view = transport ? transport->Render(lighting, v.camera, v.pose, to, &progress)
                                        : RenderView(scene, lighting, v.camera, v.pose, mc, k, &progress);
    RenderedCamera out;
    out.name = v.name;
    const std::string stem = fs::path(v.name).replace_extension().string();
    out.exr = stem + ".exr";
    out.png = stem + ".png";
    out.mask = stem + "_mask.png";
    out.width = v.camera.width;
    out.height = v.camera.height;
    out.seconds = view.seconds;
    out.exposure = PercentileExposure(view.radiance, CountMask(view.mask) > 0 ? &view.mask : nullptr,
                                      r.tonemap_percentile);
    for (const std::string& f : {out.exr, out.png, out.mask}) EnsureDir(fs::path(JoinPath(r.output_dir, f)).parent_path());
    WriteExr(JoinPath(r.output_dir, out.exr), view.radiance);
    WritePng(JoinPath(r.output_dir, out.png), ToneMapSrgb(view.radiance, out.exposure));
    WritePng(JoinPath(r.output_dir, out.mask), view.mask);
    OrderedJson e;
    e["name"] = out.name;
    e["exr"] = out.exr;
    e["png"] = out.png;
    e["mask"] = out.mask;
    e["exposure"] = out.exposure;
    e["seconds"] = out.seconds;
    e["camera"] = CameraToJson(v.camera, v.pose);
    index.push_back(e);
    summary.images.push_back(out);
  }
  summary.seconds = total.Seconds();
  OrderedJson j;
  j["format"] = "relight-render";
  j["version"] = 1;
  j["envmap"] = r.envmap;
  j["convention"] = summary.convention;
  j["rotate_deg"] = r.rotate_deg;
  j["strength"] = r.strength;
  j["renderer"] = r.renderer;
  j["cameras"] = r.cameras_dir;
  j["images"] = index;
  j["seconds"] = summary.seconds;
  WriteJsonAtomic(JoinPath(r.output_dir, "render_summary.json"), j);
  return summary;
}

}  // namespace relight
