#include "observe/observe.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "geometry/mesh_io.h"
#include "sphere/frame.h"

namespace relight {
namespace fs = std::filesystem;

Image RenderDepthMap(const RayCaster& caster, const Camera& camera, const ImageRecord& pose) {
  Image depth(camera.width, camera.height, 1, 0.0f);
  const Eigen::Matrix3d world_from_cam = pose.CamFromWorldRotation().transpose();
  const Eigen::Vector3f center = pose.ProjectionCenter().cast<float>();
  tbb::parallel_for(0, camera.height, [&](int y) {
    std::vector<Ray> rays(camera.width);
    std::vector<Eigen::Vector3d> dirs_cam(camera.width);
    for (int x = 0; x < camera.width; ++x) {
      dirs_cam[x] = camera.RayFromImage({x + 0.5, y + 0.5});
      rays[x] = Ray{center, (world_from_cam * dirs_cam[x]).cast<float>()};
    }
    std::vector<RayHit> hits;
    caster.IntersectStream(rays, true, &hits);
    for (int x = 0; x < camera.width; ++x) {
      if (hits[x].hit) depth.at(x, y) = static_cast<float>(hits[x].t * dirs_cam[x].z());
    }
  });
  return depth;
}

Image DepthEdgeDistance(const Image& depth, double relative_jump) {
  cv::Mat non_edge(depth.height, depth.width, CV_8U, cv::Scalar(255));
  auto is_edge_pair = [&](float a, float b) {
    if ((a > 0) != (b > 0)) return true;  // silhouette
    if (a <= 0) return false;             // both background
    return std::abs(a - b) > relative_jump * std::min(a, b);
  };
  for (int y = 0; y < depth.height; ++y) {
    for (int x = 0; x < depth.width; ++x) {
      const float d = depth.at(x, y);
      if (d <= 0) continue;  // background pixels are not observed anyway
      bool edge = x == 0 || y == 0 || x == depth.width - 1 || y == depth.height - 1;
      if (!edge) {
        edge = is_edge_pair(d, depth.at(x - 1, y)) || is_edge_pair(d, depth.at(x + 1, y)) ||
               is_edge_pair(d, depth.at(x, y - 1)) || is_edge_pair(d, depth.at(x, y + 1));
      }
      if (edge) non_edge.at<uint8_t>(y, x) = 0;
    }
  }
  cv::Mat dist;
  cv::distanceTransform(non_edge, dist, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  Image out(depth.width, depth.height, 1);
  for (int y = 0; y < depth.height; ++y)
    for (int x = 0; x < depth.width; ++x) out.at(x, y) = dist.at<float>(y, x);
  return out;
}

std::vector<float> VertexFootprintRadius(const TriangleMesh& mesh) {
  std::vector<double> area(mesh.num_vertices(), 0.0);
  for (size_t f = 0; f < mesh.num_faces(); ++f) {
    const double a = mesh.FaceArea(static_cast<int>(f)) / 3.0;
    for (int k = 0; k < 3; ++k) area[mesh.faces[f][k]] += a;
  }
  std::vector<float> r(mesh.num_vertices());
  for (size_t i = 0; i < r.size(); ++i) r[i] = static_cast<float>(std::sqrt(area[i] / M_PI));
  return r;
}

namespace {

// Premultiplied (radiance × confidence, confidence) pyramid for footprint
// sampling, and the plain radiance pyramid for lower bounds over clipped footprints.
struct Pyramid {
  std::vector<Image> weighted;    // RGB, radiance × confidence
  std::vector<Image> confidence;  // 1 channel
  std::vector<Image> plain;       // RGB, radiance (clipped pixels at their clipped value); empty unless kept
  std::vector<Image> over;        // RGB, 1 where the channel is over-exposed; empty unless kept and known

  Pyramid(const Image& radiance, const Image& conf, bool keep_plain, double overexposed_linear,
          int max_levels = 6) {
    Image w(radiance.width, radiance.height, 3);
    for (int y = 0; y < radiance.height; ++y)
      for (int x = 0; x < radiance.width; ++x)
        for (int c = 0; c < 3; ++c) w.at(x, y, c) = radiance.at(x, y, c) * conf.at(x, y);
    weighted.push_back(std::move(w));
    confidence.push_back(conf);
    if (keep_plain) plain.push_back(radiance);
    if (keep_plain && std::isfinite(overexposed_linear)) {
      // 1e-5: float rounding of the stored linear values (an 8-bit step is far wider).
      const float level = static_cast<float>(overexposed_linear * (1.0 - 1e-5));
      Image o(radiance.width, radiance.height, 3);
      for (size_t k = 0; k < o.pixels.size(); ++k) o.pixels[k] = radiance.pixels[k] >= level ? 1.0f : 0.0f;
      over.push_back(std::move(o));
    }
    while (static_cast<int>(weighted.size()) < max_levels && weighted.back().width >= 8 &&
           weighted.back().height >= 8) {
      weighted.push_back(Half(weighted.back()));
      confidence.push_back(Half(confidence.back()));
      if (!plain.empty()) plain.push_back(Half(plain.back()));
      if (!over.empty()) over.push_back(Half(over.back()));
    }
  }
  static Image Half(const Image& in) {
    Image out(in.width / 2, in.height / 2, in.channels);
    for (int y = 0; y < out.height; ++y)
      for (int x = 0; x < out.width; ++x)
        for (int c = 0; c < in.channels; ++c)
          out.at(x, y, c) = 0.25f * (in.at(2 * x, 2 * y, c) + in.at(2 * x + 1, 2 * y, c) +
                                     in.at(2 * x, 2 * y + 1, c) + in.at(2 * x + 1, 2 * y + 1, c));
    return out;
  }

  // Calls `tap(level, x, y)` for the taps of a disc of `radius_px` (level-0
  // pixels) around `center_px`, at the pyramid level where the disc spans about
  // 1.5 to 3 pixels; returns the number of taps.
  template <typename Tap>
  int ForEachTap(const Eigen::Vector2d& center_px, double radius_px, Tap&& tap) const {
    const FootprintTaps layout = FootprintTapLayout(radius_px, static_cast<int>(weighted.size()));
    const int level = layout.level, k = layout.taps;
    const double s = 1.0 / (1 << level);
    const double r = layout.radius;
    int n = 0;
    for (int j = -k; j <= k; ++j) {
      for (int i = -k; i <= k; ++i) {
        const double dx = r * i / k, dy = r * j / k;
        if (dx * dx + dy * dy > r * r + 1e-9) continue;
        tap(level, center_px.x() * s + dx, center_px.y() * s + dy);
        ++n;
      }
    }
    return n;
  }

  // Confidence-weighted mean colour over the disc; returns the mean confidence over it.
  double Sample(const Eigen::Vector2d& center_px, double radius_px, float rgb[3]) const {
    double sum_w[3] = {0, 0, 0}, sum_c = 0;
    const int n = ForEachTap(center_px, radius_px, [&](int level, double x, double y) {
      float w[3], c;
      SampleBilinear(weighted[level], x, y, w);
      SampleBilinear(confidence[level], x, y, &c);
      for (int q = 0; q < 3; ++q) sum_w[q] += w[q];
      sum_c += c;
    });
    if (sum_c <= 1e-9) return 0.0;
    for (int q = 0; q < 3; ++q) rgb[q] = static_cast<float>(sum_w[q] / sum_c);
    return sum_c / n;
  }

  // Unweighted mean of an RGB pyramid (`plain` or `over`) over the same taps as Sample.
  void Mean(const std::vector<Image>& pyramid, const Eigen::Vector2d& center_px, double radius_px,
            float mean[3]) const {
    double sum[3] = {0, 0, 0};
    const int n = ForEachTap(center_px, radius_px, [&](int level, double x, double y) {
      float p[3];
      SampleBilinear(pyramid[level], x, y, p);
      for (int q = 0; q < 3; ++q) sum[q] += p[q];
    });
    for (int q = 0; q < 3; ++q) mean[q] = static_cast<float>(sum[q] / std::max(1, n));
  }
};

}  // namespace

FootprintTaps FootprintTapLayout(double radius_px, int levels) {
  FootprintTaps t;
  while (t.level + 1 < levels && radius_px / (1 << (t.level + 1)) >= 1.5) ++t.level;
  t.radius = radius_px / (1 << t.level);
  t.taps = std::clamp(static_cast<int>(std::ceil(t.radius)), 1, 3);
  return t;
}

double FootprintKernelRadiusPx(double radius_px, int levels) {
  const FootprintTaps t = FootprintTapLayout(radius_px, levels);
  // Mean squared distance of the taps from the centre (the same grid as ForEachTap).
  double sum = 0;
  int n = 0;
  for (int j = -t.taps; j <= t.taps; ++j)
    for (int i = -t.taps; i <= t.taps; ++i) {
      const double dx = t.radius * i / t.taps, dy = t.radius * j / t.taps;
      if (dx * dx + dy * dy > t.radius * t.radius + 1e-9) continue;
      sum += dx * dx + dy * dy;
      ++n;
    }
  const double pixel = double(1 << t.level);  // level pixel in level-0 pixels
  // E|d|² of the kernel = taps' (in level-0 pixels) + 2 × pixel² / 4; a uniform disc of radius R has R² / 2.
  const double second_moment = sum / n * pixel * pixel + 0.5 * pixel * pixel;
  return std::sqrt(2.0 * second_moment);
}

namespace {

double Ramp(double x, double zero_at, double one_at) {
  if (one_at == zero_at) return x >= one_at ? 1.0 : 0.0;
  return std::clamp((x - zero_at) / (one_at - zero_at), 0.0, 1.0);
}

}  // namespace

std::vector<Observation> ObservePhoto(const TriangleMesh& mesh, const std::vector<float>& footprint_radius,
                                      const RayCaster& caster, const PhotoView& photo, uint32_t photo_index,
                                      const ObserveOptions& o, size_t* clipped_footprints) {
  RELIGHT_CHECK(mesh.normals.size() == mesh.vertices.size()) << "observe needs vertex normals";
  RELIGHT_CHECK(photo.radiance->width == photo.camera.width && photo.radiance->height == photo.camera.height);
  const Image depth = RenderDepthMap(caster, photo.camera, photo.pose);
  const Image edge_distance = DepthEdgeDistance(depth, o.depth_edge_jump);
  const bool lower_bounds = o.clipped_footprints == "lower_bound";
  const Pyramid pyramid(*photo.radiance, *photo.confidence, lower_bounds,
                        o.bound_channels == "clipped" ? photo.overexposed_linear
                                                      : std::numeric_limits<double>::infinity());
  const Eigen::Vector3d center = photo.pose.ProjectionCenter();
  const double edge_tolerance = 0.5 * mesh.MeanEdgeLength();
  const double cos_zero = std::cos(o.grazing_min_deg * M_PI / 180.0);
  const double focal = std::sqrt(photo.camera.FocalX() * photo.camera.FocalY());
  const int w = photo.camera.width, h = photo.camera.height;

  std::vector<Observation> slots(mesh.num_vertices());
  std::vector<uint8_t> valid(mesh.num_vertices(), 0);
  std::atomic<size_t> clipped{0};
  tbb::parallel_for(size_t(0), mesh.num_vertices(), [&](size_t v) {
    // A vertex in no face (scanned meshes such as the Stanford bunny have a few)
    // is no surface point: no area, no meaningful normal. It is never observed.
    if (!(footprint_radius[v] > 0)) return;
    const Eigen::Vector3d x = mesh.vertices[v].cast<double>();
    const Eigen::Vector3d n = mesh.normals[v].cast<double>();
    const Eigen::Vector3d to_camera = center - x;
    const double dist = to_camera.norm();
    if (dist <= 0) return;
    const Eigen::Vector3d view = to_camera / dist;
    const double cos_view = n.dot(view);
    if (cos_view <= cos_zero) return;  // back-facing or too grazing
    const Eigen::Vector3d p_cam = photo.pose.CamFromWorld(x);
    if (p_cam.z() <= 0) return;
    const Eigen::Vector2d px = photo.camera.ImageFromCamera(p_cam);
    if (px.x() < o.border_margin_px || px.y() < o.border_margin_px || px.x() > w - o.border_margin_px ||
        px.y() > h - o.border_margin_px) {
      return;
    }
    const int ix = std::clamp(static_cast<int>(px.x()), 0, w - 1), iy = std::clamp(static_cast<int>(px.y()), 0, h - 1);
    const double d = depth.at(ix, iy);
    if (d <= 0 || std::abs(d - p_cam.z()) > o.depth_tolerance * p_cam.z() + edge_tolerance) return;  // occluded
    const double nominal_px = o.footprint_scale * focal * footprint_radius[v] * std::sqrt(cos_view) / p_cam.z();
    const double radius_px = std::max(0.5, nominal_px);
    const double edge_factor =
        o.edge_margin_px > 0 ? Ramp(edge_distance.at(ix, iy) - radius_px, 0.0, o.edge_margin_px) : 1.0;
    if (edge_factor <= 0) return;
    Observation obs;
    const double pixel_confidence = pyramid.Sample(px, radius_px, obs.rgb);
    if (nominal_px > 0) {
      obs.kernel_scale = static_cast<float>(
          FootprintKernelRadiusPx(radius_px, static_cast<int>(pyramid.weighted.size())) / nominal_px);
    }
    const double angle_deg = std::acos(std::min(1.0, cos_view)) * 180.0 / M_PI;
    const double geometric_confidence = Ramp(angle_deg, o.grazing_min_deg, o.grazing_full_deg) * edge_factor;
    double confidence = pixel_confidence * geometric_confidence;
    // Clipped pixels are the footprint's brightest (or darkest): the mean of the rest is biased, not noisier.
    // Over-exposed pixels are known per channel (bound_channels = clipped): a footprint holding any is a
    // bound in those channels whatever its distrusted share, since even one clipped highlight pixel can
    // carry much of the footprint's energy (docs/RESULTS.md@15cf301, item 16). Other distrusted pixels (black-clipped,
    // next to a clipped pixel) bias the mean only over max_distrusted_share.
    float over_share[3] = {0, 0, 0};  // each channel's share of over-exposed pixels
    bool over_exposed = false;
    if (lower_bounds && !pyramid.over.empty() && pixel_confidence < 1.0 - 1e-6) {
      pyramid.Mean(pyramid.over, px, radius_px, over_share);
      over_exposed = over_share[0] > 1e-6f || over_share[1] > 1e-6f || over_share[2] > 1e-6f;
    }
    if (over_exposed || 1.0 - pixel_confidence > o.max_distrusted_share + 1e-6) {  // 1e-6: rounding of the taps
      if (geometric_confidence < o.min_confidence || geometric_confidence <= 0) return;
      clipped.fetch_add(1, std::memory_order_relaxed);
      if (!lower_bounds) return;
      // Every pixel at its value, clipped ones at the clip level: at most the true mean in the
      // channels that clipped. With bound_channels = clipped, a channel with no over-exposed pixel
      // in the footprint measures its mean. When no channel clipped (black-clipped or next to a
      // clipped pixel) or which did is unknown, all three are bounds.
      pyramid.Mean(pyramid.plain, px, radius_px, obs.rgb);
      uint32_t channels = 0;
      for (int c = 0; c < 3; ++c)
        if (over_share[c] > 1e-6f) channels |= ObservationBoundChannel(c);
      obs.flags = kObservationLowerBound | (channels == kObservationBoundChannels ? 0u : channels);
      confidence = geometric_confidence;
    } else if (confidence < o.min_confidence || confidence <= 0) {
      return;
    }
    obs.photo = photo_index;
    obs.vertex = static_cast<uint32_t>(v);
    obs.confidence = static_cast<float>(confidence);
    const Eigen::Vector3d local = FrameFromNormal<double>(n).ToLocal(view);
    for (int k = 0; k < 3; ++k) obs.view_local[k] = static_cast<float>(local[k]);
    slots[v] = obs;
    valid[v] = 1;
  });
  std::vector<Observation> out;
  for (size_t v = 0; v < slots.size(); ++v)
    if (valid[v]) out.push_back(slots[v]);
  if (clipped_footprints != nullptr) *clipped_footprints = clipped.load();
  return out;
}

std::string ObserveSummary::BriefReport() const {
  return fmt::format(
      "observe: {} observations of {} vertices in {} photos ({} from an earlier run), {} vertices "
      "unobserved; {} footprints with clipped pixels, {} of them kept as lower bounds in {} of their {} "
      "channels; {}",
      observations, vertices, photos, reused_photos, unobserved_vertices, clipped_footprints, lower_bounds,
      lower_bound_channels, 3 * lower_bounds, Progress::FormatSeconds(seconds));
}

ObserveSummary RunObserve(const ObserveOptions& options, const ObserveInputs& inputs, const std::string& output_dir,
                          const ShardSpec& shard) {
  const std::string &sfm_dir = inputs.sfm_dir, &mesh_dir = inputs.mesh_dir, &linearize_dir = inputs.linearize_dir;
  Timer timer;
  ObserveSummary summary;
  const Reconstruction model = Reconstruction::Read(JoinPath(sfm_dir, "sparse"));
  TriangleMesh mesh = ReadMesh(JoinPath(mesh_dir, "mesh.ply"));
  if (mesh.empty()) RELIGHT_USER_ERROR() << "'" << mesh_dir << "/mesh.ply' has no faces; check the mesh stage";
  if (mesh.normals.size() != mesh.num_vertices()) mesh.ComputeVertexNormals();
  summary.vertices = mesh.num_vertices();
  TriangleMesh occluders;
  const std::string occluders_path = JoinPath(mesh_dir, "occluders.ply");
  if (fs::exists(occluders_path)) occluders = ReadMesh(occluders_path);
  std::vector<const TriangleMesh*> scene{&mesh};
  if (!occluders.empty()) scene.push_back(&occluders);
  const RayCaster caster(scene);
  const std::vector<float> footprint = VertexFootprintRadius(mesh);

  // Photos: registered images that have a linear image, in name order.
  std::vector<const ImageRecord*> images;
  for (const auto& [id, im] : model.images) {
    const std::string stem = fs::path(im.name).stem().string();
    if (fs::exists(JoinPath(linearize_dir, "linear/" + stem + ".exr"))) {
      images.push_back(&im);
    } else {
      RLOG_WARN("registered photo '{}' has no linear image in {}; it is not used", im.name, linearize_dir);
    }
  }
  std::sort(images.begin(), images.end(), [](const ImageRecord* a, const ImageRecord* b) { return a->name < b->name; });
  if (images.empty()) {
    RELIGHT_USER_ERROR() << "no registered photo of '" << sfm_dir << "/sparse' has a linear image in '"
                         << linearize_dir << "'; the sfm and linearize stages disagree on photo names";
  }
  summary.photos = static_cast<int>(images.size());
  EnsureDir(JoinPath(output_dir, "per_photo"));

  std::vector<ObservedPhoto> photos(images.size());
  std::vector<std::vector<Observation>> per_photo(images.size());
  std::vector<int64_t> clipped_per_photo(images.size(), -1);  // -1: observed by an earlier, killed run
  int64_t owned = 0;
  for (size_t i = 0; i < images.size(); ++i) owned += shard.Owns(i);
  Progress progress("observe photos", owned);
  for (size_t i = 0; i < images.size(); ++i) {
    if (!shard.Owns(i)) continue;
    const ImageRecord& im = *images[i];
    const std::string stem = fs::path(im.name).stem().string();
    ObservedPhoto& p = photos[i];
    p.index = static_cast<uint32_t>(i);
    p.name = im.name;
    p.linear = "linear/" + stem + ".exr";
    p.pose = im;
    const std::string cache = JoinPath(output_dir, "per_photo/" + std::to_string(i) + "_" + stem + ".bin");
    const Image radiance = ReadImage(JoinPath(linearize_dir, p.linear));
    p.camera = model.cameras.at(im.camera_id);
    if (p.camera.width != radiance.width || p.camera.height != radiance.height) {
      const double sx = double(radiance.width) / p.camera.width, sy = double(radiance.height) / p.camera.height;
      if (std::abs(sx - sy) > 0.01 * sx) {
        RELIGHT_USER_ERROR() << "photo '" << im.name << "': the camera is " << p.camera.width << "x" << p.camera.height
                             << " but the linear image is " << radiance.width << "x" << radiance.height
                             << "; the photo was cropped after SfM — rerun from ingest";
      }
      p.camera.Rescale(sx);
      p.camera.width = radiance.width;
      p.camera.height = radiance.height;
    }
    // The clipped-footprint count, written before the observations, which mark the photo as done.
    const std::string clipped_path = JoinPath(output_dir, "per_photo/" + std::to_string(i) + "_" + stem + ".json");
    if (fs::exists(cache)) {
      per_photo[i] = ReadObservations(cache).records;  // finished by an earlier, killed run or by a shard
      ++summary.reused_photos;
      if (fs::exists(clipped_path)) {
        clipped_per_photo[i] = ReadJsonFile(clipped_path).value("clipped_footprints", int64_t{-1});
        if (clipped_per_photo[i] > 0) summary.clipped_footprints += static_cast<size_t>(clipped_per_photo[i]);
      }
    } else {
      const Image confidence = ReadImage(JoinPath(linearize_dir, "confidence/" + stem + ".exr"));
      PhotoView view{p.camera, im, &radiance, &confidence};
      // Which channels clipped (linearize stats; absent before linearize version 2: all are bounds).
      const std::string stats_path = JoinPath(linearize_dir, "stats/" + stem + ".json");
      if (fs::exists(stats_path)) {
        const Json stats = ReadJsonFile(stats_path);
        if (stats.contains("overexposed_linear") && stats["overexposed_linear"].is_number()) {
          const double level = stats["overexposed_linear"].get<double>();
          if (std::isfinite(level) && level > 0) {
            view.overexposed_linear = level;
          } else {
            RLOG_WARN("'{}': overexposed_linear = {} is not a positive radiance; every channel of a clipped "
                      "footprint becomes a bound (rerun linearize to restore it)",
                      stats_path, level);
          }
        }
      }
      size_t clipped = 0;
      per_photo[i] = ObservePhoto(mesh, footprint, caster, view, p.index, options, &clipped);
      clipped_per_photo[i] = static_cast<int64_t>(clipped);
      summary.clipped_footprints += clipped;
      WriteJsonAtomic(clipped_path, Json{{"clipped_footprints", clipped}});
      ObservationSet one{static_cast<uint32_t>(images.size()), static_cast<uint32_t>(mesh.num_vertices()), per_photo[i]};
      WriteObservations(cache, one);
    }
    double conf = 0;
    for (const auto& o : per_photo[i]) conf += o.confidence;
    p.observed_vertices = static_cast<uint32_t>(per_photo[i].size());
    p.mean_confidence = per_photo[i].empty() ? 0.0 : conf / per_photo[i].size();
    if (p.observed_vertices == 0) RLOG_WARN("photo '{}' observes no vertex of the mesh", im.name);
    progress.Advance();
  }
  progress.Finish();
  if (shard.active()) return summary;  // the unsharded run that follows gathers the photos

  ObservationSet all;
  all.num_photos = static_cast<uint32_t>(images.size());
  all.num_vertices = static_cast<uint32_t>(mesh.num_vertices());
  std::vector<int> per_vertex(mesh.num_vertices(), 0);  // exact observations (lower bounds do not count)
  std::vector<size_t> lower_bounds_per_photo(images.size(), 0);
  for (size_t i = 0; i < per_photo.size(); ++i) {
    for (const auto& o : per_photo[i]) {
      all.records.push_back(o);
      if (o.lower_bound()) {
        ++lower_bounds_per_photo[i];
        ++summary.lower_bounds;
        for (int c = 0; c < 3; ++c) summary.lower_bound_channels += o.lower_bound(c);
      } else {
        ++per_vertex[o.vertex];
      }
    }
  }
  WriteObservations(JoinPath(output_dir, "observations.bin"), all);
  WriteObservedPhotos(JoinPath(output_dir, "photos.json"), photos, options.footprint_scale);
  summary.observations = all.records.size();
  summary.unobserved_vertices = std::count(per_vertex.begin(), per_vertex.end(), 0);

  OrderedJson coverage;
  coverage["vertices"] = mesh.num_vertices();
  coverage["observations"] = summary.observations;
  coverage["unobserved_vertices"] = summary.unobserved_vertices;
  coverage["clipped_footprints"] = summary.clipped_footprints;
  coverage["lower_bounds"] = summary.lower_bounds;
  coverage["lower_bound_channels"] = summary.lower_bound_channels;
  std::map<int, int> histogram;
  for (int c : per_vertex) ++histogram[std::min(c, 20)];
  Json hist = Json::object();
  for (const auto& [k, v] : histogram) hist[k == 20 ? "20+" : std::to_string(k)] = v;
  coverage["photos_per_vertex_histogram"] = hist;
  Json per = Json::array();
  for (size_t i = 0; i < photos.size(); ++i) {
    const ObservedPhoto& p = photos[i];
    Json entry = {{"name", p.name},
                  {"observed_vertices", p.observed_vertices},
                  {"observed_fraction", double(p.observed_vertices) / std::max<size_t>(1, mesh.num_vertices())},
                  {"mean_confidence", p.mean_confidence}};
    if (clipped_per_photo[i] >= 0) entry["clipped_footprints"] = clipped_per_photo[i];
    entry["lower_bounds"] = lower_bounds_per_photo[i];
    per.push_back(entry);
  }
  coverage["photos"] = per;
  summary.seconds = timer.Seconds();
  coverage["reused_photos"] = summary.reused_photos;
  coverage["seconds"] = summary.seconds;
  WriteJsonAtomic(JoinPath(output_dir, "coverage.json"), coverage);
  if (summary.unobserved_vertices > mesh.num_vertices() / 2) {
    RLOG_WARN("more than half of the vertices are seen in no photo; is the mesh in the SfM frame?");
  }
  return summary;
}

}  // namespace relight
