#include "mvs/mvs.h"

#include <algorithm>
#include <filesystem>
#include <cmath>
#include <functional>
#include <list>
#include <map>
#include <memory>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "geometry/mesh_io.h"
#include "geometry/reconstruction.h"
#include "mvs/cgal_poisson.h"
#include "mvs/colmap_tools.h"
#include "mvs/hole_filling.h"
#include "mvs/mesh_metrics.h"
#include "mvs/mesh_preview.h"
#include "mvs/patch_match.h"
#include "mvs/view_selection.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

constexpr const char* kPhotometric = "photometric";
constexpr const char* kGeometric = "geometric";
// Geometric-pass maps before filtering (not read by COLMAP).
constexpr const char* kGeometricUnfiltered = "geometric_unfiltered";

// Maps of geometric iteration `k` (1-based) of `n`: the last one's are the unfiltered geometric maps; the
// earlier ones are kept until the last is complete, so a killed run resumes at the iteration it was in.
std::string GeometricIterationType(int k, int n) {
  return k == n ? std::string(kGeometricUnfiltered) : std::string(kGeometricUnfiltered) + "_" + std::to_string(k);
}

// FNV-1a of the image name: a random stream per image that does not depend on processing order.
uint64_t NameSeed(const std::string& name) {
  uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : name) h = (h ^ c) * 1099511628211ULL;
  return h;
}

// Keeps the most recently used grey images in memory.
class GrayImageCache {
 public:
  GrayImageCache(const MvsWorkspace& workspace, std::vector<StereoView>* views, size_t capacity)
      : workspace_(workspace), views_(*views), capacity_(capacity) {}

  // Loads views `indices` (evicting others beyond the capacity, never these).
  void Require(const std::vector<int>& indices) {
    for (int i : indices) {
      lru_.remove(i);
      lru_.push_front(i);
      if (views_[i].gray.empty()) views_[i].gray = LoadGrayImage(workspace_, views_[i]);
    }
    while (lru_.size() > std::max(capacity_, indices.size())) {
      views_[lru_.back()].gray = Image();
      lru_.pop_back();
    }
  }

 private:
  const MvsWorkspace& workspace_;
  std::vector<StereoView>& views_;
  size_t capacity_;
  std::list<int> lru_;
};

Json ReportToJson(const MvsImageReport& r) {
  Json j;
  j["name"] = r.name;
  j["width"] = r.width;
  j["height"] = r.height;
  j["sources"] = r.sources;
  j["depth_min"] = r.depth_min;
  j["depth_max"] = r.depth_max;
  j["seconds_photometric"] = r.seconds_photometric;
  j["seconds_geometric"] = r.seconds_geometric;
  j["mean_cost"] = r.mean_cost;
  j["valid_fraction"] = r.valid_fraction;
  return j;
}

void ReportFromJson(const Json& j, MvsImageReport* r) {
  r->seconds_photometric = j.value("seconds_photometric", 0.0);
  r->seconds_geometric = j.value("seconds_geometric", 0.0);
  r->mean_cost = j.value("mean_cost", 0.0);
  r->valid_fraction = j.value("valid_fraction", 0.0);
}

}  // namespace

std::string MvsSummary::BriefReport() const {
  std::ostringstream s;
  s << "mvs (" << engine << "): " << num_reference_images << "/" << num_images << " images with depth maps";
  if (num_reused > 0) s << " (" << num_reused << " from an earlier run)";
  s << ", " << fused_points << " fused points";
  if (mesher != "none") {
    s << ", mesh " << mesh_vertices << " vertices / " << mesh_faces << " triangles ("
      << (mesh_closed ? "closed" : std::to_string(mesh_boundary_edges) + " boundary edges") << ")";
  }
  s << ", " << Progress::FormatSeconds(seconds);
  return s.str();
}

namespace {

// COLMAP's stereo_fusion finds the images to fuse with through shared sparse points; a model without them
// (cameras given as ground truth) fuses nothing. This many points or fewer get points from the depth maps.
constexpr size_t kMinSparsePoints = 100;

// Adds 3D points sampled from the final depth maps (about 2000 per image), each with the track of the
// views whose maps agree within 1% of depth, and writes the model into the workspace (new files; the
// hard links into the sfm stage's folder are replaced, never written through). Returns the points added.
size_t AddPointsFromDepthMaps(const MvsWorkspace& workspace, const std::vector<StereoView>& views,
                              const std::vector<ViewSelection>& plans, const std::vector<int>& refs,
                              const std::string& type, Reconstruction* model) {
  std::map<int, std::unique_ptr<DepthNormalMap>> maps;
  for (int r : refs) {
    if (workspace.HasMaps(views[r].name, type)) {
      maps[r] = std::make_unique<DepthNormalMap>(workspace.ReadMaps(views[r], type));
    }
  }
  uint64_t next_id = 1;
  for (const auto& [id, point] : model->points3d) next_id = std::max(next_id, id + 1);
  size_t added = 0;
  for (const auto& [r, map] : maps) {
    const StereoView& ref = views[r];
    const int step = std::max(4, static_cast<int>(std::sqrt(double(ref.width) * ref.height / 2000.0)));
    const Eigen::Matrix3d K_inv = ref.K.inverse();
    for (int row = step / 2; row < ref.height; row += step) {
      for (int col = step / 2; col < ref.width; col += step) {
        const float d = map->depth[map->index(col, row)];
        if (!(d > 0)) continue;
        const Eigen::Vector3d X_cam = d * (K_inv * Eigen::Vector3d(col + 0.5, row + 0.5, 1.0));
        const Eigen::Vector3d X = ref.R_cam_from_world.transpose() * (X_cam - ref.t_cam_from_world);
        std::vector<int> track = {r};
        for (int s : plans[r].sources) {
          const auto it = maps.find(s);
          if (it == maps.end()) continue;
          const Eigen::Vector3d x = views[s].R_cam_from_world * X + views[s].t_cam_from_world;
          if (!(x.z() > 0)) continue;
          const Eigen::Vector3d p = views[s].K * (x / x.z());
          const int c = static_cast<int>(p.x()), rr = static_cast<int>(p.y());
          if (p.x() < 0 || p.y() < 0 || c >= views[s].width || rr >= views[s].height) continue;
          const float ds = it->second->depth[it->second->index(c, rr)];
          if (ds > 0 && std::abs(ds - x.z()) <= 0.01 * x.z()) track.push_back(s);
        }
        if (track.size() < 2) continue;
        Point3D point;
        point.point3d_id = next_id++;
        point.xyz = X;
        for (int v : track) {
          ImageRecord& image = model->images.at(views[v].image_id);
          Point2D observation;
          if (!model->Project(image, X, &observation.xy)) continue;
          observation.point3d_id = point.point3d_id;
          point.track.emplace_back(image.image_id, static_cast<uint32_t>(image.points2d.size()));
          image.points2d.push_back(observation);
        }
        model->points3d[point.point3d_id] = point;
        ++added;
      }
    }
  }
  model->WriteBinary(workspace.SparseDir());
  return added;
}

}  // namespace

std::string ComputeDepthMaps(const MvsOptions& options, const MvsWorkspace& workspace, MvsSummary* summary,
                             const ShardSpec& shard) {
  const int num_passes = MvsShardSteps(options);
  if (shard.active() && shard.step >= num_passes) {
    RELIGHT_USER_ERROR() << "mvs --step " << shard.step << ": these options have " << num_passes
                         << " passes of depth maps (0 to " << num_passes - 1 << ")";
  }
  const Reconstruction model = Reconstruction::Read(workspace.SparseDir());
  std::vector<StereoView> views;
  for (const auto& [id, image] : model.images) views.push_back(MakeStereoView(model, image, options.max_image_size));
  if (views.empty()) RELIGHT_USER_ERROR() << "'" << workspace.SparseDir() << "' has no registered images";
  const std::vector<ViewSelection> plans = SelectViews(model, views, options);
  summary->num_images = static_cast<int>(views.size());
  summary->images.clear();
  std::vector<int> refs;
  for (const ViewSelection& plan : plans) {
    MvsImageReport report;
    const StereoView& v = views[plan.ref];
    report.name = v.name;
    report.width = v.width;
    report.height = v.height;
    for (int s : plan.sources) report.sources.push_back(views[s].name);
    report.depth_min = plan.depth_min;
    report.depth_max = plan.depth_max;
    report.skipped = plan.skip_reason;
    if (plan.skip_reason.empty()) {
      refs.push_back(plan.ref);
    } else {
      RLOG_WARN("image {} gets no depth map: {}", v.name, plan.skip_reason);
    }
    summary->images.push_back(report);
  }
  if (refs.empty()) {
    RELIGHT_USER_ERROR() << "no image of '" << workspace.SparseDir() << "' can be a reference image ("
                         << views[0].name << ": " << plans[0].skip_reason << "): the photos overlap too little "
                         << "or too few are registered; add photos, or lower mvs.min_shared_points / "
                         << "mvs.min_triangulation_angle_deg";
  }
  if (!shard.active()) WritePatchMatchConfig(workspace, views, plans);
  summary->num_reference_images = static_cast<int>(refs.size());
  summary->reference_megapixels = 0;
  for (int r : refs) summary->reference_megapixels += views[r].width * double(views[r].height) * 1e-6;

  GrayImageCache images(workspace, &views, std::max<size_t>(24, 2 * options.max_source_images + 2));
  const auto problem_for = [&](int r) {
    const ViewSelection& plan = plans[r];
    std::vector<int> needed = plan.sources;
    needed.push_back(r);
    images.Require(needed);
    PatchMatchProblem problem;
    problem.ref = &views[r];
    for (int s : plan.sources) problem.sources.push_back(&views[s]);
    problem.depth_min = plan.depth_min;
    problem.depth_max = plan.depth_max;
    problem.image_seed = NameSeed(views[r].name);
    return problem;
  };
  const std::string final_type = options.geom_consistency ? kGeometric : kPhotometric;

  // The reference images this process computes: all, or a shard's.
  std::vector<int> own_refs;
  for (size_t k = 0; k < refs.size(); ++k) {
    if (shard.Owns(k)) own_refs.push_back(refs[k]);
  }
  // Pass `pass` (0-based, of num_passes) runs here: every pass, or the shard's one.
  const auto runs = [&](int pass) { return !shard.active() || shard.step == pass; };
  // Runs `compute` for every own reference image whose `type` maps are missing (resume) and writes them. The
  // report starts from the `previous` pass's (written by whichever process ran it: a shard, an earlier run).
  const auto run_pass = [&](const std::string& type, const std::string& previous, const std::string& label,
                            const std::function<DepthNormalMap(int r, MvsImageReport* report)>& compute) {
    Progress progress(label, static_cast<int64_t>(own_refs.size()));
    int done = 0, reused = 0;
    for (int r : own_refs) {
      ++done;
      MvsImageReport& report = summary->images[r];
      const std::string report_path = workspace.ReportPath(views[r].name, type);
      if (workspace.HasMaps(views[r].name, type) && fs::exists(report_path)) {
        ReportFromJson(ReadJsonFile(report_path), &report);
        if (type == final_type) {
          report.reused = true;
          ++summary->num_reused;
        }
        ++reused;
        progress.Advance();
        continue;
      }
      const std::string previous_report = previous.empty() ? "" : workspace.ReportPath(views[r].name, previous);
      if (!previous_report.empty() && fs::exists(previous_report)) ReportFromJson(ReadJsonFile(previous_report), &report);
      Timer timer;
      const DepthNormalMap map = compute(r, &report);
      workspace.WriteMaps(views[r], map, type);
      EnsureDir(fs::path(report_path).parent_path().string());
      WriteJsonAtomic(report_path, ReportToJson(report));
      RLOG_INFO("[{}/{}] {} {}: {}x{}, {} sources, cost {:.3f}, {:.0f}% of pixels with depth, {:.1f}s", done,
                own_refs.size(), label, views[r].name, views[r].width, views[r].height, plans[r].sources.size(),
                report.mean_cost, 100 * report.valid_fraction, timer.Seconds());
      progress.Advance();
    }
    // A resumed run says what it did not recompute.
    if (reused > 0) RLOG_INFO("{}: {} of {} images reused from an earlier run", label, reused, own_refs.size());
  };
  // The `type` maps of the sources of `r` (nullptr where missing), owned by `storage`.
  const auto source_maps = [&](int r, const std::string& type, std::vector<std::unique_ptr<DepthNormalMap>>* storage,
                               PatchMatchProblem* problem) {
    for (int s : plans[r].sources) {
      storage->push_back(workspace.HasMaps(views[s].name, type)
                             ? std::make_unique<DepthNormalMap>(workspace.ReadMaps(views[s], type))
                             : nullptr);  // a source without maps adds the maximal geometric cost
      problem->source_maps.push_back(storage->back().get());
    }
  };

  // Pass 0: photometric (filtered right away when it is the last pass).
  if (runs(0)) run_pass(kPhotometric, "", "photometric depth maps", [&](int r, MvsImageReport* report) {
    const PatchMatchProblem problem = problem_for(r);
    PatchMatchStats stats;
    DepthNormalMap map = RunPatchMatch(options, problem, /*geometric=*/false, options.num_iterations, nullptr, 0,
                                       CostKernel::kVectorized, &stats);
    report->seconds_photometric = stats.seconds;
    report->mean_cost = stats.mean_cost;
    report->valid_fraction = map.ValidFraction();
    if (!options.geom_consistency) report->valid_fraction = FilterDepthMap(options, problem, false, &map).valid_after;
    return map;
  });
  if (options.geom_consistency) {
    // Passes 1..n: PatchMatch with the reprojection error against the sources' maps, one iteration at a time: each
    // starts from the image's own maps of the iteration before and matches against its sources' maps of the
    // iteration before (the photometric ones first). Sources that improved in one iteration so help the next;
    // iterating against fixed photometric maps instead gains little.
    const int n = options.geom_iterations;
    const bool last_done = !shard.active() && std::all_of(refs.begin(), refs.end(), [&](int r) {
      return workspace.HasMaps(views[r].name, kGeometricUnfiltered) &&
             fs::exists(workspace.ReportPath(views[r].name, kGeometricUnfiltered));
    });
    for (int k = last_done ? n : 1; k <= n; ++k) {
      if (!runs(k)) continue;
      const std::string previous = k == 1 ? std::string(kPhotometric) : GeometricIterationType(k - 1, n);
      const std::string label = n == 1 ? std::string("geometric depth maps")
                                       : "geometric depth maps " + std::to_string(k) + "/" + std::to_string(n);
      run_pass(GeometricIterationType(k, n), previous, label, [&](int r, MvsImageReport* report) {
        PatchMatchProblem problem = problem_for(r);
        std::vector<std::unique_ptr<DepthNormalMap>> storage;
        source_maps(r, previous, &storage, &problem);
        const DepthNormalMap own = workspace.ReadMaps(views[r], previous);
        PatchMatchStats stats;
        DepthNormalMap map = RunPatchMatch(options, problem, /*geometric=*/true, 1, &own,
                                           options.num_iterations + k - 1, CostKernel::kVectorized, &stats);
        report->seconds_geometric = (k == 1 ? 0.0 : report->seconds_geometric) + stats.seconds;
        report->mean_cost = stats.mean_cost;
        report->valid_fraction = map.ValidFraction();
        return map;
      });
    }
    // Pass n + 1: keep pixels that the sources' geometric maps confirm.
    if (runs(n + 1)) run_pass(kGeometric, kGeometricUnfiltered, "filtering", [&](int r, MvsImageReport* report) {
      PatchMatchProblem problem = problem_for(r);
      std::vector<std::unique_ptr<DepthNormalMap>> storage;
      source_maps(r, kGeometricUnfiltered, &storage, &problem);
      DepthNormalMap map = workspace.ReadMaps(views[r], kGeometricUnfiltered);
      report->valid_fraction = FilterDepthMap(options, problem, true, &map).valid_after;
      return map;
    });
    // The maps of the earlier iterations, once no pass reads them.
    if (!shard.active()) {
      for (int k = 1; k < n; ++k) {
        for (int r : refs) workspace.RemoveMaps(views[r].name, GeometricIterationType(k, n));
      }
    }
  }
  if (shard.active()) return final_type;  // the unsharded run that follows densifies and writes fusion.cfg

  if (model.points3d.size() <= kMinSparsePoints) {
    Reconstruction densified = model;
    const size_t added = AddPointsFromDepthMaps(workspace, views, plans, refs, final_type, &densified);
    RLOG_INFO("the sparse model has {} points: added {} from the depth maps so stereo fusion finds overlapping "
              "images", model.points3d.size(), added);
  }
  std::vector<std::string> fused_names;
  for (int r : refs) fused_names.push_back(views[r].name);
  WriteFusionConfig(workspace, fused_names);
  return final_type;
}

MvsSummary RunMvs(const MvsOptions& options, const MvsInputs& inputs, const std::string& output_dir,
                  const ShardSpec& shard) {
  const std::string& sfm_dir = inputs.sfm_dir;
  Timer total;
  MvsSummary summary;
  summary.engine = options.engine;
  summary.mesher = options.mesher;
  Timer step;
  const MvsWorkspace workspace = PrepareMvsWorkspace(sfm_dir, output_dir);
  summary.step_seconds.emplace_back("workspace", step.Seconds());

  step.Restart();
  if (shard.active()) {
    if (MvsShardSteps(options) == 0) {
      RELIGHT_USER_ERROR() << "mvs.engine: " << options.engine << " cannot be split into shards; run it whole";
    }
    ComputeDepthMaps(options, workspace, &summary, shard);
    return summary;  // the unsharded run that follows fuses and meshes
  }
  std::string input_type;
  if (options.engine == "colmap") {
    // COLMAP picks its own sources (__auto__) and fuses every image.
    const Reconstruction model = Reconstruction::Read(workspace.SparseDir());
    std::string patch_match_cfg, names;
    for (const auto& [id, image] : model.images) {
      patch_match_cfg += image.name + "\n__auto__, " + std::to_string(options.max_source_images) + "\n";
      names += image.name + "\n";
    }
    WriteFileAtomic(workspace.StereoDir() + "/patch-match.cfg", patch_match_cfg);
    WriteFileAtomic(workspace.StereoDir() + "/fusion.cfg", names);
    RunColmapPatchMatch(options, workspace.dir);
    summary.num_images = summary.num_reference_images = static_cast<int>(model.images.size());
    input_type = options.geom_consistency ? kGeometric : kPhotometric;
  } else {
    input_type = ComputeDepthMaps(options, workspace, &summary);
  }
  summary.step_seconds.emplace_back("depth_maps", step.Seconds());

  step.Restart();
  const std::string fused_path = JoinPath(output_dir, "fused.ply");
  summary.fused_points = RunStereoFusion(options, workspace.dir, input_type, fused_path);
  summary.step_seconds.emplace_back("fusion", step.Seconds());
  RLOG_INFO("stereo fusion: {} points", summary.fused_points);

  if (options.mesher != "none") {
    step.Restart();
    const std::string mesh_path = JoinPath(output_dir, "meshed.ply");
    if (options.mesher == "colmap_poisson") {
      RunColmapPoisson(options, fused_path, mesh_path);
    } else {
      CgalPoissonStats stats;
      const TriangleMesh mesh = CgalPoissonReconstruct(ReadMesh(fused_path), &stats);
      WriteMeshPly(mesh_path, mesh);
    }
    TriangleMesh mesh = ReadMesh(mesh_path);
    if (options.close_holes && !AnalyzeTopology(mesh).closed()) {
      const HoleFillingStats holes = FillHoles(&mesh);
      summary.holes_filled = holes.holes_filled;
      if (holes.holes_failed > 0) RLOG_WARN("{} holes of the mesh could not be closed", holes.holes_failed);
      WriteMeshPly(mesh_path, mesh);
    }
    summary.step_seconds.emplace_back("meshing", step.Seconds());
    const MeshTopology topology = AnalyzeTopology(mesh);
    summary.mesh_vertices = mesh.num_vertices();
    summary.mesh_faces = mesh.num_faces();
    summary.mesh_boundary_edges = topology.boundary_edges;
    summary.mesh_nonmanifold_edges = topology.nonmanifold_edges;
    summary.mesh_closed = topology.closed();
    if (options.write_preview) {
      step.Restart();
      const Reconstruction model = Reconstruction::Read(workspace.SparseDir());
      const StereoView view = MakeStereoView(model, model.images.begin()->second, options.max_image_size);
      WriteImage(JoinPath(output_dir, "meshed_preview.png"), RenderMeshPreview(mesh, view));
      summary.step_seconds.emplace_back("preview", step.Seconds());
    }
  }
  summary.seconds = total.Seconds();
  WriteMvsSummary(summary, JoinPath(output_dir, "mvs_summary.json"));
  return summary;
}

void WriteMvsSummary(const MvsSummary& s, const std::string& path) {
  OrderedJson j;
  j["engine"] = s.engine;
  j["num_images"] = s.num_images;
  j["num_reference_images"] = s.num_reference_images;
  j["num_reused"] = s.num_reused;
  j["reference_megapixels"] = s.reference_megapixels;
  j["fused_points"] = s.fused_points;
  j["mesher"] = s.mesher;
  j["mesh"] = {{"vertices", s.mesh_vertices},
               {"faces", s.mesh_faces},
               {"holes_filled", s.holes_filled},
               {"boundary_edges", s.mesh_boundary_edges},
               {"nonmanifold_edges", s.mesh_nonmanifold_edges},
               {"closed", s.mesh_closed}};
  OrderedJson steps = OrderedJson::object();
  for (const auto& [name, seconds] : s.step_seconds) steps[name] = seconds;
  j["step_seconds"] = steps;
  j["seconds"] = s.seconds;
  OrderedJson images = OrderedJson::array();
  for (const auto& r : s.images) {
    OrderedJson im;
    im["name"] = r.name;
    im["width"] = r.width;
    im["height"] = r.height;
    if (!r.skipped.empty()) {
      im["skipped"] = r.skipped;
    } else {
      im["sources"] = r.sources;
      im["depth_range"] = {r.depth_min, r.depth_max};
      im["reused"] = r.reused;
      im["seconds_photometric"] = r.seconds_photometric;
      im["seconds_geometric"] = r.seconds_geometric;
      im["mean_cost"] = r.mean_cost;
      im["valid_fraction"] = r.valid_fraction;
    }
    images.push_back(im);
  }
  j["images"] = images;
  WriteJsonAtomic(path, j);
}

}  // namespace relight
