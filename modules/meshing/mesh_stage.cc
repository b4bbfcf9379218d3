// The mesh stage (see mesh_stage.h): source selection, cropping to the region
// the cameras saw, CGAL clean-up (mesh_cleanup.cc), orientation of open
// meshes by camera visibility (Embree ray casting), outputs.
#include "meshing/mesh_stage.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <optional>
#include <random>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/timer.h"
#include "geometry/mesh_io.h"
#include "geometry/point_grid.h"
#include "geometry/raycaster.h"
#include "image/image.h"
#include "meshing/geometry_views.h"

namespace relight {
namespace fs = std::filesystem;

namespace {

Eigen::Vector3d FaceCentroid(const TriangleMesh& mesh, size_t f) {
  const auto& t = mesh.faces[f];
  return ((mesh.vertices[t[0]] + mesh.vertices[t[1]] + mesh.vertices[t[2]]) / 3.0f).cast<double>();
}

Sim3 ReadWorldFromColmap(const std::string& sfm_dir) {
  const Json j = ReadJsonFile(JoinPath(sfm_dir, "sfm_summary.json"));
  Sim3 t;
  const Json& w = j.at("world_from_colmap");
  t.scale = w.at("scale").get<double>();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) t.rotation(r, c) = w.at("rotation").at(r).at(c).get<double>();
    t.translation[r] = w.at("translation").at(r).get<double>();
  }
  return t;
}

void TransformMesh(const Sim3& t, TriangleMesh* mesh) {
  for (auto& v : mesh->vertices) v = t.Apply(v.cast<double>()).cast<float>();
  for (auto& n : mesh->normals) n = (t.rotation.cast<float>() * n).normalized();
}

void WriteSummary(const MeshSummary& s, const MeshOptions& options, const std::string& path) {
  OrderedJson j;
  j["format"] = "relight-mesh-summary";
  j["version"] = 1;
  j["source"] = s.source;
  j["input"] = s.input_path;
  j["input_vertices"] = s.input_vertices;
  j["input_faces"] = s.input_faces;
  j["cleaned"] = s.cleaned;
  j["faces_cropped_box"] = s.faces_cropped_box;
  j["faces_cropped_views"] = s.faces_cropped_views;
  j["faces_cropped_distance"] = s.faces_cropped_distance;
  if (s.cleaned) {
    const MeshCleanupSummary& c = s.cleanup;
    OrderedJson cj;
    cj["duplicate_points_merged"] = c.duplicate_points_merged;
    cj["soup_polygons_removed"] = c.soup_polygons_removed;
    cj["non_manifold_points_duplicated"] = c.non_manifold_points_duplicated;
    cj["degenerate_faces_removed"] = c.degenerate_faces_removed;
    cj["components_found"] = c.components_found;
    cj["component_ranking"] = c.component_ranking;
    cj["components_removed"] = c.components_removed;
    cj["faces_removed_with_components"] = c.faces_removed_with_components;
    cj["holes_filled"] = c.holes_filled;
    cj["holes_left"] = c.holes_left;
    cj["hole_faces_added"] = c.hole_faces_added;
    cj["target_vertices"] = options.target_vertices;
    cj["resample"] = options.resample;
    cj["target_edge_length"] = c.target_edge_length;
    cj["resample_passes"] = c.resample_passes;
    OrderedJson steps;
    for (const auto& [name, seconds] : c.step_seconds) steps[name] = seconds;
    cj["step_seconds"] = steps;
    j["cleanup"] = cj;
  }
  j["closed"] = s.boundary_edges == 0;
  j["boundary_edges"] = s.boundary_edges;
  j["components"] = s.components;
  j["manifold"] = s.manifold;
  j["orientation"] = s.orientation_method;
  j["orientation_flipped"] = s.orientation_flipped || s.cleanup.orientation_reversed;
  j["output_vertices"] = s.output_vertices;
  j["output_faces"] = s.output_faces;
  j["occluder_faces"] = s.occluder_faces;
  j["seconds"] = s.seconds;
  WriteJsonAtomic(path, j);
}

}  // namespace

std::string MeshSummary::BriefReport() const {
  std::ostringstream s;
  s << "mesh (" << source << "): " << input_vertices << " -> " << output_vertices << " vertices, " << output_faces
    << " faces, " << components << " component(s), " << (boundary_edges == 0 ? "closed" : "open") << ", "
    << (manifold ? "2-manifold" : "NOT manifold");
  if (cleaned) {
    s << "; cropped " << faces_cropped_box + faces_cropped_views + faces_cropped_distance << " faces, removed "
      << cleanup.components_removed << " component(s), filled " << cleanup.holes_filled << " hole(s) ("
      << cleanup.holes_left << " left open)";
  }
  s << "; orientation " << orientation_method << "; " << seconds << " s";
  return s.str();
}

Eigen::AlignedBox3d SparsePointBox(const Reconstruction& model, double percentile, double margin) {
  Eigen::AlignedBox3d box;
  if (model.points3d.size() < 10) return box;
  std::vector<double> coords[3];
  for (const auto& [id, p] : model.points3d) {
    for (int k = 0; k < 3; ++k) coords[k].push_back(p.xyz[k]);
  }
  Eigen::Vector3d lo, hi;
  for (int k = 0; k < 3; ++k) {
    auto& c = coords[k];
    std::sort(c.begin(), c.end());
    const size_t i_lo = static_cast<size_t>(percentile / 100.0 * (c.size() - 1));
    const size_t i_hi = static_cast<size_t>((1.0 - percentile / 100.0) * (c.size() - 1));
    lo[k] = c[i_lo];
    hi[k] = c[i_hi];
  }
  // The margin is a fraction of the box's largest side on every axis, not of
  // each axis' own extent. A textured ground carries most sparse points of a
  // typical capture, so the vertical percentiles land inside the object and a
  // per-axis margin crops its top (measured on synthetic_tiny: 7% of the points
  // lie above the ground, and the per-axis box top sat at the knot's top).
  const double grow = margin * (hi - lo).maxCoeff();
  box.extend(lo - Eigen::Vector3d::Constant(grow));
  box.extend(hi + Eigen::Vector3d::Constant(grow));
  return box;
}

TriangleMesh CropMesh(const TriangleMesh& mesh, const CropRegion& region, size_t* removed_by_box,
                      size_t* removed_by_views, size_t* removed_by_distance) {
  std::vector<uint8_t> keep(mesh.faces.size(), 1);
  // Occupied voxels of the data points (cell = max_distance).
  const bool use_distance = region.points != nullptr && !region.points->empty() && region.max_distance > 0;
  std::optional<PointGrid> data_grid;
  if (use_distance) data_grid.emplace(*region.points, region.max_distance);
  std::atomic<size_t> by_distance{0};
  std::vector<const ImageRecord*> images;
  if (region.cameras != nullptr) {
    for (const auto& [id, im] : region.cameras->images) images.push_back(&im);
  }
  const int min_views = std::min<int>(region.min_views, static_cast<int>(images.size()));
  std::atomic<size_t> by_box{0}, by_views{0};
  tbb::parallel_for(size_t(0), mesh.faces.size(), [&](size_t f) {
    const Eigen::Vector3d c = FaceCentroid(mesh, f);
    if (region.use_box && !region.box.contains(c)) {
      keep[f] = 0;
      ++by_box;
      return;
    }
    if (use_distance && !data_grid->AnyPointInNeighbourCells(c)) {
      keep[f] = 0;
      ++by_distance;
      return;
    }
    if (min_views > 0) {
      int views = 0;
      for (const ImageRecord* im : images) {
        Eigen::Vector2d pixel;
        double depth = 0;
        if (!region.cameras->Project(*im, c, &pixel, &depth) || depth <= 0) continue;
        const Camera& cam = region.cameras->cameras.at(im->camera_id);
        if (pixel.x() >= 0 && pixel.y() >= 0 && pixel.x() <= cam.width && pixel.y() <= cam.height) {
          if (++views >= min_views) break;
        }
      }
      if (views < min_views) {
        keep[f] = 0;
        ++by_views;
      }
    }
  });
  *removed_by_box = by_box;
  *removed_by_views = by_views;
  if (removed_by_distance != nullptr) *removed_by_distance = by_distance;
  TriangleMesh out;
  std::vector<int> remap(mesh.vertices.size(), -1);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    if (!keep[f]) continue;
    Eigen::Vector3i t;
    for (int k = 0; k < 3; ++k) {
      int& r = remap[mesh.faces[f][k]];
      if (r < 0) {
        r = static_cast<int>(out.vertices.size());
        out.vertices.push_back(mesh.vertices[mesh.faces[f][k]]);
      }
      t[k] = r;
    }
    out.faces.push_back(t);
  }
  return out;
}

bool OrientOutward(const Reconstruction* cameras, TriangleMesh* mesh, std::string* method) {
  if (mesh->faces.empty()) return false;
  std::vector<size_t> sample(mesh->faces.size());
  for (size_t i = 0; i < sample.size(); ++i) sample[i] = i;
  if (sample.size() > 20000) {
    std::mt19937 rng(7);
    std::shuffle(sample.begin(), sample.end(), rng);
    sample.resize(20000);
  }
  double vote = 0;
  if (cameras != nullptr && !cameras->images.empty()) {
    *method = "cameras";
    RayCaster caster({mesh});
    std::vector<Eigen::Vector3d> centers;
    for (const auto& [id, im] : cameras->images) centers.push_back(im.ProjectionCenter());
    if (centers.size() > 64) {  // a spread subset is plenty for a sign vote
      std::vector<Eigen::Vector3d> subset;
      for (size_t i = 0; i < 64; ++i) subset.push_back(centers[i * centers.size() / 64]);
      centers = subset;
    }
    std::vector<double> votes(sample.size(), 0.0);
    tbb::parallel_for(size_t(0), sample.size(), [&](size_t i) {
      const size_t f = sample[i];
      const Eigen::Vector3d p = FaceCentroid(*mesh, f);
      const Eigen::Vector3f n = mesh->FaceNormal(static_cast<int>(f));
      const double area = mesh->FaceArea(static_cast<int>(f));
      for (const auto& c : centers) {
        Ray ray;
        ray.origin = c.cast<float>();
        ray.dir = (p - c).cast<float>();
        ray.t_far = 1.0f + 1e-3f;
        const RayHit hit = caster.Intersect(ray);
        if (!hit.hit || hit.prim_id != f) continue;  // hidden behind other faces
        votes[i] += area * (n.cast<double>().dot(c - p) > 0 ? 1.0 : -1.0);
      }
    });
    for (double v : votes) vote += v;
  }
  if (vote == 0) {
    *method = "centroid";
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& v : mesh->vertices) centroid += v.cast<double>();
    centroid /= double(mesh->vertices.size());
    for (size_t f : sample) {
      vote += mesh->FaceArea(static_cast<int>(f)) *
              mesh->FaceNormal(static_cast<int>(f)).cast<double>().dot(FaceCentroid(*mesh, f) - centroid);
    }
  }
  if (vote >= 0) return false;
  for (auto& t : mesh->faces) std::swap(t[1], t[2]);
  mesh->ComputeVertexNormals();
  return true;
}

namespace {

// views/: the mesh (and the fused MVS points) seen from a few of the photos' cameras, and views.json
// listing them (geometry_views.h).
void WriteGeometryViews(const Reconstruction& cameras, const TriangleMesh& mesh, const std::string& mvs_dir,
                        const std::string& output_dir) {
  const std::string dir = JoinPath(output_dir, "views");
  std::error_code ec;
  fs::remove_all(dir, ec);
  EnsureDir(dir);
  const std::string fused_path = mvs_dir.empty() ? "" : JoinPath(mvs_dir, "fused.ply");
  TriangleMesh fused;
  if (!fused_path.empty() && fs::is_regular_file(fused_path)) fused = ReadMesh(fused_path);
  const int kViews = 4, kMaxSize = 400;
  WriteOptions png;
  png.type = PixelType::kUint8;
  OrderedJson views = OrderedJson::array();
  for (const ImageRecord* image : SpreadViews(cameras, kViews)) {
    const Camera& camera = cameras.cameras.at(image->camera_id);
    const std::string stem = fs::path(image->name).stem().string();
    OrderedJson v;
    v["photo"] = image->name;
    WriteImage(JoinPath(dir, stem + "_mesh.png"), RenderMeshView(mesh, camera, *image, kMaxSize), png);
    v["mesh"] = "views/" + stem + "_mesh.png";
    if (!fused.vertices.empty()) {
      WriteImage(JoinPath(dir, stem + "_points.png"), RenderPointsView(fused, camera, *image, kMaxSize), png);
      v["points"] = "views/" + stem + "_points.png";
    }
    views.push_back(v);
  }
  OrderedJson j;
  j["views"] = views;
  j["fused_points"] = fused.vertices.size();
  WriteJsonAtomic(JoinPath(output_dir, "views.json"), j);
}

}  // namespace

MeshSummary RunMesh(const MeshOptions& options, const MeshInputs& inputs, const std::string& output_dir) {
  Timer timer;
  MeshSummary summary;
  summary.source = options.source;

  std::unique_ptr<Reconstruction> cameras;
  if (!inputs.sfm_dir.empty() && fs::is_directory(JoinPath(inputs.sfm_dir, "sparse"))) {
    cameras = std::make_unique<Reconstruction>(Reconstruction::Read(JoinPath(inputs.sfm_dir, "sparse")));
  }

  TriangleMesh mesh;
  TriangleMesh occluders;
  const bool known = !inputs.known_mesh.empty();  // the true mesh, given by the stage's main
  RELIGHT_CHECK(known || options.source == "mvs" || options.source == "file")
      << "mesh.source " << options.source << " needs the known mesh (MeshInputs::known_mesh)";
  if (known) {
    summary.input_path = inputs.known_mesh;
    mesh = ReadMesh(summary.input_path);
    if (!inputs.known_occluders.empty()) occluders = ReadMesh(inputs.known_occluders);
  } else if (options.source == "mvs") {
    if (inputs.mvs_dir.empty()) {
      RELIGHT_USER_ERROR() << "mesh.source is mvs but no mvs stage output was given (--input mvs=DIR); run the mvs "
                              "stage or set mesh.source: file with mesh.file";
    }
    summary.input_path = JoinPath(inputs.mvs_dir, "meshed.ply");
    if (!fs::is_regular_file(summary.input_path)) {
      RELIGHT_USER_ERROR() << "the mvs stage wrote no mesh at '" << summary.input_path
                           << "'; rerun it (pipeline run --force mvs) or set mesh.source: file";
    }
    mesh = ReadMesh(summary.input_path);
  } else {
    summary.input_path = options.file;
    mesh = ReadMesh(options.file);
    if (options.file_frame == "colmap") {
      if (inputs.sfm_dir.empty()) {
        RELIGHT_USER_ERROR() << "mesh.file_frame is colmap, which needs the sfm stage's output (its "
                                "world_from_colmap transform); pass --input sfm=DIR or set mesh.file_frame: world";
      }
      TransformMesh(ReadWorldFromColmap(inputs.sfm_dir), &mesh);
    }
  }
  summary.input_vertices = mesh.vertices.size();
  summary.input_faces = mesh.faces.size();
  if (mesh.empty()) RELIGHT_USER_ERROR() << "'" << summary.input_path << "' holds no triangles";
  RLOG_INFO("input mesh {}: {} vertices, {} faces", summary.input_path, mesh.vertices.size(), mesh.faces.size());

  const bool clean = !known || options.clean_ground_truth;
  summary.cleaned = clean;
  if (clean) {
    // Crop to the region the cameras saw, and to the user's box.
    CropRegion region;
    std::vector<Eigen::Vector3d> data_points;
    if (!options.crop_box.empty()) {
      region.use_box = true;
      region.box = Eigen::AlignedBox3d(Eigen::Vector3d(options.crop_box[0], options.crop_box[1], options.crop_box[2]),
                                       Eigen::Vector3d(options.crop_box[3], options.crop_box[4], options.crop_box[5]));
    }
    if (options.auto_crop && !known) {
      if (cameras == nullptr) {
        RLOG_WARN("mesh.auto_crop is on but no sfm output was given: the mesh is not cropped to the cameras");
      } else {
        const Eigen::AlignedBox3d sparse_box = SparsePointBox(*cameras, options.crop_percentile, options.crop_margin);
        if (!sparse_box.isEmpty()) {
          region.box = region.use_box ? region.box.intersection(sparse_box) : sparse_box;
          region.use_box = true;
          RLOG_INFO(
              "auto crop: sparse-point box [{:.3g} {:.3g} {:.3g}] - [{:.3g} {:.3g} {:.3g}], faces in front of "
              ">= {} camera(s)",
              sparse_box.min().x(), sparse_box.min().y(), sparse_box.min().z(), sparse_box.max().x(),
              sparse_box.max().y(), sparse_box.max().z(), options.crop_min_views);
        }
        region.cameras = cameras.get();
        region.min_views = options.crop_min_views;
      }
      // Data points: the fused dense cloud when there is one, else the sparse points.
      const std::string fused = inputs.mvs_dir.empty() ? "" : JoinPath(inputs.mvs_dir, "fused.ply");
      if (!fused.empty() && fs::is_regular_file(fused)) {
        for (const auto& v : ReadMesh(fused).vertices) data_points.push_back(v.cast<double>());
      } else if (cameras != nullptr) {
        for (const auto& [id, p] : cameras->points3d) data_points.push_back(p.xyz);
      }
      if (options.max_point_distance > 0 && data_points.size() >= 10) {
        Eigen::AlignedBox3d box;
        for (const auto& p : data_points) box.extend(p);
        region.points = &data_points;
        region.max_distance = options.max_point_distance * box.diagonal().norm();
        RLOG_INFO("auto crop: faces farther than {:.3g} from all {} {} points go", region.max_distance,
                  data_points.size(), fused.empty() || !fs::is_regular_file(fused) ? "sparse" : "fused");
      }
    }
    if (region.use_box || region.min_views > 0 || region.points != nullptr) {
      mesh = CropMesh(mesh, region, &summary.faces_cropped_box, &summary.faces_cropped_views,
                      &summary.faces_cropped_distance);
      RLOG_INFO(
          "crop: removed {} faces outside the box, {} far from the points and {} seen by too few cameras; "
          "{} faces left",
          summary.faces_cropped_box, summary.faces_cropped_distance, summary.faces_cropped_views, mesh.faces.size());
      if (mesh.faces.empty()) {
        RELIGHT_USER_ERROR() << "cropping removed every face of '" << summary.input_path
                             << "': the mesh is not where the cameras look (wrong frame? see mesh.file_frame), or "
                                "mesh.crop_box is off; disable mesh.auto_crop to keep it all";
      }
    }
    MeshCleanupOptions c;
    c.target_vertices = options.target_vertices;
    c.remesh = options.resample == "remesh";
    c.max_components = options.max_components;
    c.min_component_fraction = options.min_component_fraction;
    if (!data_points.empty() && region.max_distance > 0) {
      c.support_points = &data_points;  // rank the parts by the data near them, not by area
      c.support_radius = region.max_distance;
    }
    c.max_hole_edges = options.max_hole_edges;
    c.max_hole_fraction = options.max_hole_fraction;
    c.remesh_iterations = options.remesh_iterations;
    mesh = CleanMesh(mesh, c, summary.input_path, &summary.cleanup);
    summary.orientation_method = summary.cleanup.closed ? "volume" : "";
    if (!summary.cleanup.closed) {
      summary.orientation_flipped = OrientOutward(cameras.get(), &mesh, &summary.orientation_method);
    }
    for (const auto& [name, seconds] : summary.cleanup.step_seconds) RLOG_INFO("  {}: {:.2f} s", name, seconds);
  } else {
    summary.orientation_method = "as given";
    if (mesh.normals.size() != mesh.vertices.size()) mesh.ComputeVertexNormals();
    if (!occluders.empty() && occluders.normals.size() != occluders.vertices.size()) occluders.ComputeVertexNormals();
  }

  summary.boundary_edges = CountBoundaryEdges(mesh);
  summary.components = CountComponents(mesh);
  const std::string violation = FindManifoldViolation(mesh);
  summary.manifold = violation.empty();
  if (!summary.manifold) RLOG_WARN("the output mesh is not a 2-manifold: {}", violation);
  summary.output_vertices = mesh.vertices.size();
  summary.output_faces = mesh.faces.size();
  summary.occluder_faces = occluders.faces.size();

  WriteMeshPly(JoinPath(output_dir, "mesh.ply"), mesh);
  std::error_code ec;
  fs::remove(JoinPath(output_dir, "occluders.ply"), ec);
  if (!occluders.empty()) WriteMeshPly(JoinPath(output_dir, "occluders.ply"), occluders);
  if (cameras != nullptr) WriteGeometryViews(*cameras, mesh, inputs.mvs_dir, output_dir);
  summary.seconds = timer.Seconds();
  WriteSummary(summary, options, JoinPath(output_dir, "mesh_summary.json"));
  return summary;
}

}  // namespace relight
