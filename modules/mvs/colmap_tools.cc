#include "mvs/colmap_tools.h"

#include <filesystem>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "geometry/mesh_io.h"

namespace relight {
namespace fs = std::filesystem;

ProcessResult RunColmapTool(const std::vector<std::string>& args,
                            const std::function<void(const std::string&)>& on_line) {
  const ProcessResult run = RunColmapProcess(args, on_line);
  if (!run.started()) {
    RELIGHT_USER_ERROR() << run.start_error << ": install COLMAP (apt-get install colmap) or set RELIGHT_COLMAP "
                         << "to its path";
  }
  return run;
}

bool ColmapHasCuda(std::string* banner) {
  // "COLMAP 3.8 -- Structure-from-Motion ..." then "(Commit ... on ... without CUDA)" / "with CUDA".
  std::vector<std::string> head;
  RunColmapTool({"help"}, [&](const std::string& line) {
    if (head.size() < 10) head.push_back(line);
  });
  bool cuda = false;
  std::string version;
  for (const auto& line : head) {
    if (version.empty() && line.rfind("COLMAP", 0) == 0) version = line.substr(0, line.find(" --"));
    if (line.find("with CUDA") != std::string::npos && line.find("without CUDA") == std::string::npos) cuda = true;
    if (line.find("CUDA") != std::string::npos && banner != nullptr) {
      std::string trimmed = line.substr(line.find_first_not_of(' '));
      *banner = version + " " + trimmed;
    }
  }
  return cuda;
}

size_t RunStereoFusion(const MvsOptions& options, const std::string& workspace_dir, const std::string& input_type,
                       const std::string& output_ply) {
  AtomicFile out(output_ply);
  const ProcessResult run = RunColmapTool({"stereo_fusion",
                                           "--workspace_path", workspace_dir,
                                           "--workspace_format", "COLMAP",
                                           "--input_type", input_type,
                                           "--output_type", "PLY",
                                           "--output_path", out.temp_path(),
                                           "--StereoFusion.num_threads", "1",  // deterministic (colmap_tools.h)
                                           "--StereoFusion.min_num_pixels", std::to_string(options.fusion_min_num_pixels),
                                           "--StereoFusion.max_reproj_error", std::to_string(options.fusion_max_reproj_error_px),
                                           "--StereoFusion.max_depth_error", std::to_string(options.fusion_max_depth_error),
                                           "--StereoFusion.max_normal_error", std::to_string(options.fusion_max_normal_error_deg)});
  if (!run.ok() || !fs::exists(out.temp_path())) {
    RELIGHT_USER_ERROR() << "colmap stereo_fusion failed on '" << workspace_dir << "' (" << run.DescribeWithOutput(4)
                         << "); see stage.log";
  }
  const size_t points = ReadMesh(out.temp_path()).num_vertices();
  if (points == 0) {
    RELIGHT_USER_ERROR() << "colmap stereo_fusion fused 0 points from the depth maps in '" << workspace_dir
                         << "/stereo': the maps are empty or disagree; check the sfm cameras, or relax "
                         << "mvs.filter_min_num_consistent / mvs.fusion_min_num_pixels";
  }
  // COLMAP also writes <output>.vis (the images that see each point); keep it beside the final name.
  const std::string vis = out.temp_path() + ".vis";
  out.Commit();
  std::error_code ec;
  if (fs::exists(vis)) fs::rename(vis, output_ply + ".vis", ec);
  return points;
}

void RunColmapPoisson(const MvsOptions& options, const std::string& fused_ply, const std::string& output_ply) {
  AtomicFile out(output_ply);
  const ProcessResult run = RunColmapTool({"poisson_mesher",
                                           "--input_path", fused_ply,
                                           "--output_path", out.temp_path(),
                                           "--PoissonMeshing.depth", std::to_string(options.poisson_depth),
                                           "--PoissonMeshing.trim", std::to_string(options.poisson_trim),
                                           "--PoissonMeshing.num_threads", "1"});  // deterministic (colmap_tools.h)
  if (!run.ok() || !fs::exists(out.temp_path())) {
    RELIGHT_USER_ERROR() << "colmap poisson_mesher wrote no mesh from '" << fused_ply << "' (" << run.DescribeWithOutput(4)
                         << "); the fused points need normals (nx, ny, nz); see stage.log";
  }
  if (ReadMesh(out.temp_path()).num_faces() == 0) {
    RELIGHT_USER_ERROR() << "colmap poisson_mesher produced a mesh without triangles from '" << fused_ply
                         << "'; lower mvs.poisson_trim or check the fused points";
  }
  out.Commit();
}

void RunColmapPatchMatch(const MvsOptions& options, const std::string& workspace_dir) {
  std::string banner;
  if (!ColmapHasCuda(&banner)) {
    RELIGHT_USER_ERROR() << "mvs.engine is 'colmap' but the installed COLMAP (" << (banner.empty() ? "?" : banner)
                         << ") has no CUDA, so its patch_match_stereo cannot run; use mvs.engine: patchmatch "
                         << "(the default CPU implementation) or install a CUDA build of COLMAP";
  }
  const ProcessResult run =
      RunColmapTool({"patch_match_stereo", "--workspace_path", workspace_dir, "--workspace_format", "COLMAP",
                     "--PatchMatchStereo.geom_consistency", options.geom_consistency ? "true" : "false",
                     "--PatchMatchStereo.max_image_size", std::to_string(options.max_image_size > 0 ? options.max_image_size : -1),
                     "--PatchMatchStereo.window_radius", std::to_string(options.window_radius),
                     "--PatchMatchStereo.window_step", std::to_string(options.window_step),
                     "--PatchMatchStereo.num_iterations", std::to_string(options.num_iterations),
                     "--PatchMatchStereo.filter_min_ncc", std::to_string(options.filter_min_ncc),
                     "--PatchMatchStereo.filter_min_num_consistent", std::to_string(options.filter_min_num_consistent)});
  if (!run.ok()) {
    RELIGHT_USER_ERROR() << "colmap patch_match_stereo failed on '" << workspace_dir << "' (" << run.DescribeWithOutput(4)
                         << "); see stage.log";
  }
}

}  // namespace relight
