#include "mvs/view_selection.h"

#include <algorithm>
#include <limits>
#include <cmath>
#include <map>
#include <numeric>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "core/error.h"
#include "core/stats.h"

namespace relight {
namespace {

constexpr double kPreferredAngleDeg = 15.0;  // pose-only fallback: best triangulation angle at the scene centre
constexpr double kDepthFactor = 3.0;         // pose-only fallback: depth range within centre depth ÷/× this ...
constexpr double kOverlapFraction = 0.75;    // ... where the reference's rays are inside this many of the sources' frusta
constexpr int kOverlapRays = 32;             // rays per image side sampled for the frustum overlap

// The point closest (least squares) to every camera's optical axis; false when the axes are (nearly) parallel.
bool AxesCenter(const std::vector<StereoView>& views, Eigen::Vector3d* center) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const StereoView& v : views) {
    const Eigen::Vector3d d = v.R_cam_from_world.row(2).transpose();
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
    A += P;
    b += P * v.CenterWorld();
  }
  // A is symmetric positive semi-definite; it is singular when all axes are parallel.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(A);
  const Eigen::Vector3d lambda = eigen.eigenvalues();  // ascending
  if (!(lambda(0) > 1e-3 * lambda(2))) return false;
  *center = A.ldlt().solve(b);
  return true;
}

// Interval of ray parameters t >= 0 for which a + b t >= 0 (a and b scalars), intersected into [*lo, *hi].
void ClipHalfLine(double a, double b, double* lo, double* hi) {
  if (b > 0) {
    *lo = std::max(*lo, -a / b);
  } else if (b < 0) {
    *hi = std::min(*hi, -a / b);
  } else if (a < 0) {
    *hi = -1;  // never
  }
}

}  // namespace

bool FrustumOverlapDepthRange(const StereoView& ref, const std::vector<const StereoView*>& sources, int min_views,
                              double* depth_min, double* depth_max) {
  RELIGHT_CHECK(min_views >= 1) << min_views;
  const Eigen::Matrix3d K_inv = ref.K.inverse();
  const Eigen::Matrix3d world_from_cam = ref.R_cam_from_world.transpose();
  const Eigen::Vector3d center = ref.CenterWorld();
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  std::vector<std::pair<double, int>> events;  // (t, +1 entering / -1 leaving a frustum)
  for (int gy = 0; gy <= kOverlapRays; ++gy) {
    for (int gx = 0; gx <= kOverlapRays; ++gx) {
      // Ray through the image point, z = 1 in the reference camera: X(t) = center + t · dir_world, t = camera z.
      const Eigen::Vector3d pixel(ref.width * gx / double(kOverlapRays), ref.height * gy / double(kOverlapRays), 1);
      const Eigen::Vector3d dir_world = world_from_cam * (K_inv * pixel);
      events.clear();
      for (const StereoView* v : sources) {
        // Source image coordinates: p(t) = K (A + t B); inside when z > 0 and 0 <= x <= w·z, 0 <= y <= h·z.
        const Eigen::Vector3d A = v->K * (v->R_cam_from_world * center + v->t_cam_from_world);
        const Eigen::Vector3d B = v->K * (v->R_cam_from_world * dir_world);
        double t0 = 0, t1 = std::numeric_limits<double>::infinity();
        ClipHalfLine(A.z(), B.z(), &t0, &t1);
        ClipHalfLine(A.x(), B.x(), &t0, &t1);
        ClipHalfLine(v->width * A.z() - A.x(), v->width * B.z() - B.x(), &t0, &t1);
        ClipHalfLine(A.y(), B.y(), &t0, &t1);
        ClipHalfLine(v->height * A.z() - A.y(), v->height * B.z() - B.y(), &t0, &t1);
        if (!(t1 > t0)) continue;
        events.emplace_back(t0, +1);
        events.emplace_back(t1, -1);
      }
      // Leaving before entering at equal t: a touching pair of frusta does not overlap.
      std::sort(events.begin(), events.end());
      int inside = 0;
      for (size_t e = 0; e < events.size(); ++e) {
        const int before = inside;
        inside += events[e].second;
        if (before < min_views && inside >= min_views) lo = std::min(lo, events[e].first);
        if (before >= min_views && inside < min_views) hi = std::max(hi, events[e].first);
      }
    }
  }
  if (!(hi > lo)) return false;
  *depth_min = lo;
  *depth_max = hi;
  return true;
}

namespace {

// Views other than `ref` (and those in `exclude`) that see `center` under a triangulation angle between the
// minimum and 90°, best first (nearest to kPreferredAngleDeg), at most `limit`.
std::vector<int> SourcesFromPoses(const std::vector<StereoView>& views, int r, const Eigen::Vector3d& center,
                                  const MvsOptions& options, const std::vector<int>& exclude, int limit) {
  const StereoView& ref = views[r];
  std::vector<std::pair<double, int>> candidates;  // (|angle - preferred|, source)
  for (int s = 0; s < static_cast<int>(views.size()); ++s) {
    if (s == r || std::find(exclude.begin(), exclude.end(), s) != exclude.end()) continue;
    const Eigen::Vector3d x = views[s].R_cam_from_world * center + views[s].t_cam_from_world;
    if (!(x.z() > 0)) continue;
    const Eigen::Vector3d p = views[s].K * (x / x.z());
    if (p.x() < 0 || p.y() < 0 || p.x() > views[s].width || p.y() > views[s].height) continue;
    const Eigen::Vector3d ra = (ref.CenterWorld() - center).normalized();
    const Eigen::Vector3d rb = (views[s].CenterWorld() - center).normalized();
    const double angle = std::acos(std::clamp(ra.dot(rb), -1.0, 1.0)) * 180.0 / M_PI;
    if (angle < options.min_triangulation_angle_deg || angle > 90.0) continue;
    candidates.emplace_back(std::abs(angle - kPreferredAngleDeg), s);
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<int> sources;
  for (const auto& [score, s] : candidates) {
    if (static_cast<int>(sources.size()) >= limit) break;
    sources.push_back(s);
  }
  return sources;
}

// Appends `sources` chosen from the poses to the plan (no shared points; the angle at the scene centre).
void AddPoseSources(const std::vector<StereoView>& views, const Eigen::Vector3d& center, const std::vector<int>& sources,
                    ViewSelection* plan) {
  const StereoView& ref = views[plan->ref];
  for (int s : sources) {
    plan->sources.push_back(s);
    plan->shared_points.push_back(0);
    plan->shared_score.push_back(0.0);
    const Eigen::Vector3d ra = (ref.CenterWorld() - center).normalized();
    const Eigen::Vector3d rb = (views[s].CenterWorld() - center).normalized();
    plan->median_angle_deg.push_back(std::acos(std::clamp(ra.dot(rb), -1.0, 1.0)) * 180.0 / M_PI);
  }
}

// Sources and depth range of view r from the poses alone.
void SelectFromPoses(const std::vector<StereoView>& views, const Eigen::Vector3d& center, const MvsOptions& options,
                     ViewSelection* plan) {
  const StereoView& ref = views[plan->ref];
  const double z = (ref.R_cam_from_world * center + ref.t_cam_from_world).z();
  if (!(z > 0)) {
    plan->skip_reason = "it does not look at the scene centre (the point nearest to all optical axes)";
    return;
  }
  AddPoseSources(views, center, SourcesFromPoses(views, plan->ref, center, options, {}, options.max_source_images),
                 plan);
  plan->from_poses = true;
  plan->depth_min = z / kDepthFactor;
  plan->depth_max = z * kDepthFactor;
  // Only depths that most sources see can be matched: the frustum overlap narrows the range (a few times for a
  // ring of photos around an object: mvs_test DepthRangeWithoutSparsePointsIsTheSourcesOverlapOnARing).
  std::vector<const StereoView*> sources;
  for (int s : plan->sources) sources.push_back(&views[s]);
  const int num_sources = static_cast<int>(sources.size());
  const int min_views = std::min(num_sources, std::max(options.num_best_views,
                                                       static_cast<int>(std::ceil(kOverlapFraction * num_sources))));
  double overlap_min, overlap_max;
  if (min_views > 0 && FrustumOverlapDepthRange(ref, sources, min_views, &overlap_min, &overlap_max) &&
      overlap_min < plan->depth_max && overlap_max > plan->depth_min) {
    plan->depth_min = std::max(plan->depth_min, overlap_min);
    plan->depth_max = std::min(plan->depth_max, overlap_max);
  }
  if (plan->sources.empty()) {
    std::ostringstream reason;
    reason << "no other view sees the scene centre under a triangulation angle between "
           << options.min_triangulation_angle_deg << " and 90 deg";
    plan->skip_reason = reason.str();
  }
}

}  // namespace

std::vector<ViewSelection> SelectViews(const Reconstruction& model, const std::vector<StereoView>& views,
                                       const MvsOptions& options) {
  const int n = static_cast<int>(views.size());
  std::map<uint32_t, int> index_of;
  std::vector<Eigen::Vector3d> centers(n);
  for (int i = 0; i < n; ++i) {
    index_of[views[i].image_id] = i;
    centers[i] = views[i].CenterWorld();
  }
  // Triangulation angles of the shared points of every image pair, and their weighted count.
  std::vector<std::map<int, std::vector<double>>> angles(n);
  std::vector<std::map<int, double>> scores(n);
  std::vector<std::vector<double>> ref_depths(n);
  const double min_angle = options.min_triangulation_angle_deg;
  for (const auto& [id, point] : model.points3d) {
    std::vector<int> track;
    for (const auto& [image_id, unused] : point.track) {
      const auto it = index_of.find(image_id);
      if (it != index_of.end()) track.push_back(it->second);
    }
    std::sort(track.begin(), track.end());
    track.erase(std::unique(track.begin(), track.end()), track.end());
    for (int a : track) {
      const double z = (views[a].R_cam_from_world * point.xyz + views[a].t_cam_from_world).z();
      if (z > 0) ref_depths[a].push_back(z);
    }
    for (size_t i = 0; i < track.size(); ++i) {
      for (size_t j = i + 1; j < track.size(); ++j) {
        const Eigen::Vector3d ra = (centers[track[i]] - point.xyz).normalized();
        const Eigen::Vector3d rb = (centers[track[j]] - point.xyz).normalized();
        const double angle = std::acos(std::clamp(ra.dot(rb), -1.0, 1.0)) * 180.0 / M_PI;
        if (angle < min_angle) continue;
        angles[track[i]][track[j]].push_back(angle);
        angles[track[j]][track[i]].push_back(angle);
        const double weight = 0.5 * (1.0 + ra.dot(rb));  // (1 + cos angle) / 2
        scores[track[i]][track[j]] += weight;
        scores[track[j]][track[i]] += weight;
      }
    }
  }

  std::vector<ViewSelection> plans(n);
  Eigen::Vector3d center;
  const bool have_center = AxesCenter(views, &center);
  if (model.points3d.size() < 3) {
    // No sparse points (e.g. cameras given as ground truth): choose from the poses.
    for (int r = 0; r < n; ++r) {
      plans[r].ref = r;
      if (!have_center) {
        plans[r].skip_reason = "the model has no 3D points and the cameras' optical axes do not meet";
      } else {
        SelectFromPoses(views, center, options, &plans[r]);
      }
    }
    return plans;
  }
  for (int r = 0; r < n; ++r) {
    ViewSelection& plan = plans[r];
    plan.ref = r;
    // Rank candidates by their weighted shared points.
    std::vector<std::pair<double, int>> candidates;  // (score, source)
    for (const auto& [s, score] : scores[r]) {
      if (score >= options.min_shared_points) candidates.emplace_back(score, s);
    }
    std::sort(candidates.begin(), candidates.end(), [](const auto& a, const auto& b) {
      return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    if (static_cast<int>(candidates.size()) > options.max_source_images) candidates.resize(options.max_source_images);
    for (const auto& [score, s] : candidates) {
      plan.sources.push_back(s);
      plan.shared_points.push_back(static_cast<int>(angles[r][s].size()));
      plan.shared_score.push_back(score);
      plan.median_angle_deg.push_back(Median(angles[r][s]));
    }
    // Too few sources share points with it (few features under a light of its own): the cost's best views and
    // the filter's consistent views need more, so views that see the scene centre from a good angle join them.
    const int wanted = std::min(options.max_source_images,
                                std::max(options.num_best_views, options.filter_min_num_consistent) + 1);
    if (static_cast<int>(plan.sources.size()) < wanted && have_center &&
        (views[r].R_cam_from_world * center + views[r].t_cam_from_world).z() > 0) {
      const std::vector<int> extra =
          SourcesFromPoses(views, r, center, options, plan.sources, wanted - static_cast<int>(plan.sources.size()));
      AddPoseSources(views, center, extra, &plan);
      plan.num_pose_sources = static_cast<int>(extra.size());
    }
    // Depth range: the sparse points this image observes (all points in front and inside as a fallback).
    std::vector<double> depths = ref_depths[r];
    if (depths.size() < 10) {
      depths.clear();
      const StereoView& v = views[r];
      for (const auto& [id, point] : model.points3d) {
        const Eigen::Vector3d x = v.R_cam_from_world * point.xyz + v.t_cam_from_world;
        if (x.z() <= 0) continue;
        const Eigen::Vector3d p = v.K * (x / x.z());
        if (p.x() >= 0 && p.y() >= 0 && p.x() <= v.width && p.y() <= v.height) depths.push_back(x.z());
      }
    }
    plan.num_points = static_cast<int>(depths.size());
    if (!depths.empty()) {
      plan.depth_min = PercentileOf(depths, 1) * (1.0 - options.depth_margin);
      plan.depth_max = PercentileOf(depths, 99) * (1.0 + options.depth_margin);
      plan.depth_min = std::max(plan.depth_min, 1e-3 * plan.depth_max);
    }
    if (plan.sources.empty()) {
      std::ostringstream reason;
      reason << "no source view shares " << options.min_shared_points << " sparse points with it (weighted by "
             << "(1 + cos angle) / 2) at a triangulation angle of at least " << options.min_triangulation_angle_deg
             << " deg";
      plan.skip_reason = reason.str();
    } else if (depths.size() < 3) {
      plan.skip_reason = "too few sparse points in front of it to bound the depth range";
    }
  }
  return plans;
}

}  // namespace relight
