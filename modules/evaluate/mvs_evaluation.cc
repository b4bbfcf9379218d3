#include "evaluate/mvs_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "core/fs.h"
#include "core/stats.h"
#include "datasets/ground_truth.h"
#include "geometry/align.h"
#include "geometry/mesh_io.h"
#include "geometry/reconstruction.h"
#include "image/image.h"
#include "mvs/colmap_mat.h"
#include "mvs/mesh_metrics.h"
#include "mvs/stereo_view.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

std::string Stem(const std::string& name) { return fs::path(name).stem().string(); }

Eigen::Vector3f ApplySim(const Sim3& sim, const Eigen::Vector3f& p) {
  return sim.Apply(p.cast<double>()).cast<float>();
}

bool InBox(const Eigen::AlignedBox3f& box, const Eigen::Vector3f& p) { return box.contains(p); }

}  // namespace

OrderedJson MvsEvaluation::ToJson() const {
  OrderedJson j;
  j["map_type"] = map_type;
  j["diagonal"] = diagonal;
  j["alignment_scale"] = scale;
  j["mean_depth_completeness_object_range"] = mean_depth_completeness;
  j["min_depth_completeness_object_range"] = min_depth_completeness;
  j["mean_depth_completeness_scene_range"] = mean_depth_completeness_scene;
  j["min_depth_completeness_scene_range"] = min_depth_completeness_scene;
  j["mean_depth_completeness_visible"] = mean_depth_completeness_visible;
  j["min_depth_completeness_visible"] = min_depth_completeness_visible;
  j["mean_missing"] = mean_missing;
  j["mean_completeness_interior_object_range"] = mean_completeness_interior;
  j["mean_completeness_edge_object_range"] = mean_completeness_edge;
  j["fused_points_in_box"] = fused_points;
  j["fused_accuracy"] = fused_accuracy;
  j["fused_completeness"] = fused_completeness;
  j["fused_mean_distance_relative"] = diagonal > 0 ? fused_mean_distance / diagonal : 0.0;
  if (has_mesh) {
    j["chamfer_relative"] = chamfer / diagonal;
    j["chamfer_mesh_to_truth_relative"] = chamfer_mesh_to_truth / diagonal;
    j["chamfer_truth_to_mesh_relative"] = chamfer_truth_to_mesh / diagonal;
  }
  OrderedJson list = OrderedJson::array();
  for (const auto& v : views) {
    list.push_back({{"name", v.name},
                    {"object_pixels", v.object_pixels},
                    {"object_depth_range", v.object_depth_range},
                    {"scene_depth_range", v.scene_depth_range},
                    {"completeness_object_range", v.completeness},
                    {"completeness_scene_range", v.completeness_scene},
                    {"visible_pixels", v.visible_pixels},
                    {"completeness_visible", v.completeness_visible},
                    {"missing", v.missing},
                    {"edge_fraction", v.edge_fraction},
                    {"completeness_interior_object_range", v.completeness_interior},
                    {"completeness_edge_object_range", v.completeness_edge},
                    {"median_error_of_object_range", v.median_error},
                    {"median_signed_error_of_object_range", v.median_signed_error}});
  }
  j["views"] = list;
  return j;
}

std::string MvsEvaluation::BriefReport() const {
  std::ostringstream s;
  s.precision(3);
  s << "depth maps (" << map_type << ", " << views.size() << " views): completeness within 1% of the object's "
    << "depth range mean " << mean_depth_completeness << ", min " << min_depth_completeness
    << "; of the scene's depth range mean " << mean_depth_completeness_scene << ", min " << min_depth_completeness_scene
    << "; every visible pixel (ground included), scene range, mean " << mean_depth_completeness_visible << ", min "
    << min_depth_completeness_visible << "\n";
  s << "depth maps: object pixels without depth " << mean_missing << "; completeness (object range) inside "
    << mean_completeness_interior << ", at silhouettes/depth edges " << mean_completeness_edge << "\n";
  s << "fused: " << fused_points << " points in the object's box, accuracy " << fused_accuracy << ", completeness "
    << fused_completeness << ", mean distance " << fused_mean_distance / diagonal << " of the diagonal\n";
  if (has_mesh) {
    s << "mesh: Chamfer " << chamfer / diagonal << " of the diagonal (mesh->truth " << chamfer_mesh_to_truth / diagonal
      << ", truth->mesh " << chamfer_truth_to_mesh / diagonal << ")";
  }
  return s.str();
}

MvsEvaluation EvaluateMvs(const std::string& mvs_dir, const std::string& ground_truth_dir,
                          const MvsEvaluationOptions& options) {
  MvsEvaluation result;
  const GroundTruth gt = GroundTruth::At(ground_truth_dir);
  const Reconstruction truth = gt.ReadCameras();
  const Reconstruction estimate = Reconstruction::Read(JoinPath(mvs_dir, "dense/sparse"));
  const CameraErrors cameras = CompareCameras(estimate, truth);
  if (cameras.matched < 3) {
    RELIGHT_USER_ERROR() << "only " << cameras.matched << " images of '" << mvs_dir
                         << "/dense/sparse' match the true cameras in '" << ground_truth_dir
                         << "' by name; cannot align the reconstruction";
  }
  const Sim3 true_from_est = cameras.truth_from_estimate;
  const Sim3 est_from_true = true_from_est.Inverse();
  result.scale = true_from_est.scale;

  TriangleMesh object = ReadMesh(gt.MeshPath());
  TriangleMesh surfaces = object;
  if (gt.HasOccluders()) surfaces.Append(ReadMesh(gt.OccludersPath()));
  const Eigen::AlignedBox3f object_box = object.BoundingBox();
  result.diagonal = (object_box.max() - object_box.min()).norm();
  Eigen::AlignedBox3f box = object_box;
  const float grow = float(options.crop_margin * result.diagonal);
  box.min() -= Eigen::Vector3f::Constant(grow);
  box.max() += Eigen::Vector3f::Constant(grow);

  // ---- depth maps, view by view, compared along the true cameras' pixel rays.
  const std::string stereo = JoinPath(mvs_dir, "dense/stereo");
  for (const auto& [id, est_image] : estimate.images) {
    const ImageRecord* true_image = truth.FindImage(est_image.name);
    if (true_image == nullptr) continue;
    std::string type = options.map_type;
    if (type.empty()) {
      type = fs::exists(stereo + "/depth_maps/" + est_image.name + ".geometric.bin") ? "geometric" : "photometric";
    }
    const std::string depth_path = stereo + "/depth_maps/" + est_image.name + "." + type + ".bin";
    const std::string true_depth_path = gt.DepthPath(Stem(est_image.name));
    if (!fs::exists(depth_path) || !fs::exists(true_depth_path)) continue;
    result.map_type = type;
    const ColmapMat depth_mat = ReadColmapMat(depth_path);
    const ColmapMat normal_mat = ReadColmapMat(stereo + "/normal_maps/" + est_image.name + "." + type + ".bin");
    const StereoView est_view = MakeStereoView(estimate, est_image, std::max(depth_mat.width, depth_mat.height));
    if (est_view.width != depth_mat.width || est_view.height != depth_mat.height) {
      RELIGHT_USER_ERROR() << "'" << depth_path << "' does not have the size of its camera; rerun the mvs stage";
    }
    const DepthNormalMap map = FromColmapMaps(depth_mat, normal_mat, est_view.K, depth_path);
    const Image true_depth = ReadImage(true_depth_path);
    Image mask;
    const std::string mask_path = gt.MaskPath(Stem(est_image.name));
    if (fs::exists(mask_path)) mask = ReadImage(mask_path);
    const Camera& true_camera = truth.cameras.at(true_image->camera_id);
    StereoView true_view;  // pose only; rays come from the (possibly distorted) true camera
    true_view.R_cam_from_world = true_image->CamFromWorldRotation();
    true_view.t_cam_from_world = true_image->cam_from_world_translation;
    if (true_depth.width != true_camera.width || true_depth.height != true_camera.height) {
      RELIGHT_USER_ERROR() << "'" << true_depth_path << "' is not of the size of its camera in '" << ground_truth_dir
                           << "'";
    }
    const auto is_object = [&](int x, int y) {
      if (!(true_depth.at(x, y) > 0)) return false;
      return mask.empty() || mask.at(x, y, 0) > 0.5f;
    };
    float lo = 1e30f, hi = 0, scene_lo = 1e30f, scene_hi = 0;
    for (int y = 0; y < true_depth.height; ++y) {
      for (int x = 0; x < true_depth.width; ++x) {
        const float d = true_depth.at(x, y);
        if (d > 0) scene_lo = std::min(scene_lo, d), scene_hi = std::max(scene_hi, d);
        if (is_object(x, y)) lo = std::min(lo, d), hi = std::max(hi, d);
      }
    }
    ViewDepthScore score;
    score.name = est_image.name;
    if (!(hi > lo)) continue;
    score.object_depth_range = hi - lo;
    score.scene_depth_range = scene_hi - scene_lo;
    const double tolerance = options.depth_tolerance * (hi - lo);
    const double tolerance_scene = options.depth_tolerance * (scene_hi - scene_lo);
    // Silhouette/edge band: object pixels near a non-object pixel or a true depth step.
    const int W = true_depth.width, H = true_depth.height;
    std::vector<uint8_t> edge_seed(size_t(W) * H, 0), edge(size_t(W) * H, 0);
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) {
        if (!is_object(x, y)) {
          edge_seed[size_t(y) * W + x] = 1;
          continue;
        }
        const float d = true_depth.at(x, y);
        if ((x + 1 < W && is_object(x + 1, y) && std::abs(true_depth.at(x + 1, y) - d) > 0.02f * d) ||
            (y + 1 < H && is_object(x, y + 1) && std::abs(true_depth.at(x, y + 1) - d) > 0.02f * d)) {
          edge_seed[size_t(y) * W + x] = 1;
        }
      }
    }
    const int band = std::max(0, options.edge_band_px);
    for (int y = 0; y < H; ++y) {
      for (int x = 0; x < W; ++x) {
        if (!edge_seed[size_t(y) * W + x]) continue;
        for (int yy = std::max(0, y - band); yy <= std::min(H - 1, y + band); ++yy) {
          for (int xx = std::max(0, x - band); xx <= std::min(W - 1, x + band); ++xx) edge[size_t(yy) * W + xx] = 1;
        }
      }
    }
    const Eigen::Matrix3d true_world_from_cam = true_view.R_cam_from_world.transpose();
    const Eigen::Vector3d true_center = true_view.CenterWorld();
    size_t good = 0, good_scene = 0, missing = 0, edge_pixels = 0, good_edge = 0, good_visible = 0;
    std::vector<double> errors, signed_errors;
    // Our depth error (in the truth's units, signed: ours - true) at the true pixel (x, y), or nothing when our
    // map has no depth there.
    const auto depth_error = [&](int x, int y) -> std::optional<double> {
      // The true point of this pixel, seen from our (aligned) camera.
      const Eigen::Vector3d ray_true_cam =
          true_camera.NormalizedFromImage(Eigen::Vector2d(x + 0.5, y + 0.5)).homogeneous();
      const Eigen::Vector3d X_true = true_center + true_world_from_cam * (ray_true_cam * true_depth.at(x, y));
      const Eigen::Vector3d X_est = est_view.R_cam_from_world * est_from_true.Apply(X_true) + est_view.t_cam_from_world;
      if (!(X_est.z() > 0)) return std::nullopt;
      const Eigen::Vector3d p = est_view.K * (X_est / X_est.z());
      const int col = static_cast<int>(std::floor(p.x())), row = static_cast<int>(std::floor(p.y()));
      if (col < 0 || row < 0 || col >= map.width || row >= map.height || !(map.depth[map.index(col, row)] > 0)) {
        return std::nullopt;
      }
      // Our point on the ray through the true point: our pixel's plane intersected with that ray, else
      // (a plane seen edge-on) the pixel centre's point. The centre lies up to half a pixel beside the
      // ray wherever our pixel grid is not the true one (smaller maps, undistorted image sizes), which on
      // a slanted surface is a depth error of the scoring, not of the map.
      const size_t k = map.index(col, row);
      const Eigen::Vector3d ray_center = est_view.K.inverse() * Eigen::Vector3d(col + 0.5, row + 0.5, 1.0);
      Eigen::Vector3d Y_est_cam = ray_center * map.depth[k];
      if (options.intersect_planes) {
        const Eigen::Vector3d n = map.normal_cam[k].cast<double>();
        const Eigen::Vector3d ray = est_view.K.inverse() * Eigen::Vector3d(p.x(), p.y(), 1.0);
        const double denom = n.dot(ray);
        if (denom < -1e-3) {
          const double t = n.dot(Y_est_cam) / denom;
          if (t > 0.5 * map.depth[k] && t < 2.0 * map.depth[k]) Y_est_cam = t * ray;
        }
      }
      const Eigen::Vector3d Y_est_world =
          est_view.R_cam_from_world.transpose() * (Y_est_cam - est_view.t_cam_from_world);
      const double z = (true_view.R_cam_from_world * true_from_est.Apply(Y_est_world) + true_view.t_cam_from_world).z();
      return z - true_depth.at(x, y);
    };
    for (int y = 0; y < true_depth.height; ++y) {
      for (int x = 0; x < true_depth.width; ++x) {
        if (!(true_depth.at(x, y) > 0)) continue;
        ++score.visible_pixels;
        const std::optional<double> signed_error = depth_error(x, y);
        const double error = signed_error ? std::abs(*signed_error) : 0.0;
        if (signed_error && error <= tolerance_scene) ++good_visible;
        if (!is_object(x, y)) continue;
        ++score.object_pixels;
        const bool on_edge = edge[size_t(y) * W + x] != 0;
        edge_pixels += on_edge;
        if (!signed_error) {
          ++missing;
          continue;
        }
        errors.push_back(error / (hi - lo));
        signed_errors.push_back(*signed_error / (hi - lo));
        if (error <= tolerance) ++good, good_edge += on_edge;
        if (error <= tolerance_scene) ++good_scene;
      }
    }
    if (score.object_pixels == 0) continue;
    score.completeness = double(good) / score.object_pixels;
    score.completeness_scene = double(good_scene) / score.object_pixels;
    score.missing = double(missing) / score.object_pixels;
    score.completeness_visible = double(good_visible) / score.visible_pixels;
    score.edge_fraction = double(edge_pixels) / score.object_pixels;
    const size_t interior_pixels = score.object_pixels - edge_pixels;
    score.completeness_interior = interior_pixels > 0 ? double(good - good_edge) / interior_pixels : 0.0;
    score.completeness_edge = edge_pixels > 0 ? double(good_edge) / edge_pixels : 0.0;
    score.median_error = Median(errors);
    score.median_signed_error = Median(signed_errors);
    result.views.push_back(score);
  }
  if (!result.views.empty()) {
    result.min_depth_completeness = result.min_depth_completeness_scene = result.min_depth_completeness_visible = 1;
    const double n = double(result.views.size());
    for (const auto& v : result.views) {
      result.mean_depth_completeness += v.completeness / n;
      result.min_depth_completeness = std::min(result.min_depth_completeness, v.completeness);
      result.mean_depth_completeness_scene += v.completeness_scene / n;
      result.min_depth_completeness_scene = std::min(result.min_depth_completeness_scene, v.completeness_scene);
      result.mean_depth_completeness_visible += v.completeness_visible / n;
      result.min_depth_completeness_visible = std::min(result.min_depth_completeness_visible, v.completeness_visible);
      result.mean_missing += v.missing / n;
      result.mean_completeness_interior += v.completeness_interior / n;
      result.mean_completeness_edge += v.completeness_edge / n;
    }
  }

  // ---- fused points
  const TriangleMesh fused = ReadMesh(JoinPath(mvs_dir, "fused.ply"));
  std::vector<Eigen::Vector3f> all_points, box_points;
  for (const auto& p : fused.vertices) {
    all_points.push_back(ApplySim(true_from_est, p));
    if (InBox(box, all_points.back())) box_points.push_back(all_points.back());
  }
  result.fused_points = box_points.size();
  const std::vector<Eigen::Vector3f> object_samples = SampleSurface(object, options.surface_samples, 17);
  if (!box_points.empty()) {
    const std::vector<double> accuracy = DistancesToMesh(box_points, surfaces);
    result.fused_accuracy = FractionWithin(accuracy, options.accuracy_threshold * result.diagonal);
    result.fused_mean_distance = Mean(accuracy);
  }
  if (!all_points.empty()) {
    result.fused_completeness =
        FractionWithin(DistancesToPoints(object_samples, all_points), options.completeness_threshold * result.diagonal);
  }

  // ---- mesh
  const std::string mesh_path = JoinPath(mvs_dir, "meshed.ply");
  if (fs::exists(mesh_path)) {
    TriangleMesh mesh = ReadMesh(mesh_path);
    for (auto& v : mesh.vertices) v = ApplySim(true_from_est, v);
    TriangleMesh cropped;
    cropped.vertices = mesh.vertices;
    for (const auto& f : mesh.faces) {
      if (InBox(box, mesh.vertices[f[0]]) && InBox(box, mesh.vertices[f[1]]) && InBox(box, mesh.vertices[f[2]])) {
        cropped.faces.push_back(f);
      }
    }
    if (!cropped.faces.empty()) {
      result.has_mesh = true;
      result.chamfer_mesh_to_truth =
          Mean(DistancesToMesh(SampleSurface(cropped, options.surface_samples, 19), surfaces));
      result.chamfer_truth_to_mesh = Mean(DistancesToMesh(object_samples, mesh));
      result.chamfer = 0.5 * (result.chamfer_mesh_to_truth + result.chamfer_truth_to_mesh);
    }
  }
  return result;
}

}  // namespace relight
