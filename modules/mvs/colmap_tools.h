// The COLMAP dense tools the stage drives through the `colmap` executable
// (Debian's COLMAP 3.8 ships no library): `stereo_fusion`, `poisson_mesher`
// and, when COLMAP was built with CUDA, `patch_match_stereo`. Each run's
// output goes to the stage log; every output file is checked, since COLMAP
// exits 0 after writing nothing (../shared/COLMAP.md).
//
// The process is core/process.h's: it dies with the stage, so a killed stage leaves no orphan COLMAP behind.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/external_tools.h"  // ColmapExecutable
#include "core/process.h"
#include "mvs/mvs_options.h"

namespace relight {

// Runs `colmap <args...>`; output lines go to the stage log file and to `on_line` (may be empty). Throws
// UserError when COLMAP cannot start; the caller checks the result and the outputs.
ProcessResult RunColmapTool(const std::vector<std::string>& args,
                            const std::function<void(const std::string&)>& on_line = {});
// True when `colmap help` reports a CUDA build; `banner` receives its version line.
bool ColmapHasCuda(std::string* banner = nullptr);

// Both tools run on one thread: with more, COLMAP 3.8's fusion fuses the images in a varying order and its
// Poisson solver sums in a varying order, so the same depth maps gave a different point cloud and mesh on
// every run (and a different relit model downstream). One thread costs little: fusion took 2.7 s on two
// threads and 2.7 s on one for 20 photos, Poisson 4.4 s against 6 s at depth 9.
//
// Runs `colmap stereo_fusion` on the workspace (`input_type` photometric | geometric) into `output_ply`
// (atomically) and returns the number of fused points. Throws UserError when COLMAP fails or fuses nothing.
size_t RunStereoFusion(const MvsOptions& options, const std::string& workspace_dir, const std::string& input_type,
                       const std::string& output_ply);
// Runs `colmap poisson_mesher` on a fused PLY (with normals) into `output_ply` (atomically).
// Throws UserError when COLMAP fails or writes no triangles.
void RunColmapPoisson(const MvsOptions& options, const std::string& fused_ply, const std::string& output_ply);
// Runs COLMAP's own `patch_match_stereo` (geometric consistency, filtering) on the workspace.
// Throws UserError naming the installed COLMAP when it has no CUDA.
void RunColmapPatchMatch(const MvsOptions& options, const std::string& workspace_dir);

}  // namespace relight
