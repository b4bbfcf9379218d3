// The COLMAP dense tools the stage drives through the `colmap` executable
// (Debian's COLMAP 3.8 ships no library): `stereo_fusion`, `poisson_mesher`
// and, when COLMAP was built with CUDA, `patch_match_stereo`. Each run's
// output goes to the stage log; every output file is checked, since COLMAP
// exits 0 after writing nothing (../shared/COLMAP.md).
//
// Written by hand (fork/exec with a pipe): the stack has no process library
// that streams a child's merged output and ties its life to ours
// (PR_SET_PDEATHSIG), so a killed stage leaves no orphan COLMAP behind.
// TODO(lead): modules/sfm/colmap_command.h (written in parallel) does the same for the sfm stage; merge
// the two into one shared runner.
#pragma once

#include <string>
#include <vector>

#include "core/external_tools.h"  // ColmapExecutable
#include "mvs/mvs_options.h"

namespace relight {

// Outcome of one COLMAP command.
struct ColmapToolRun {
  int exit_code = -1;               // valid when !signaled
  bool signaled = false;            // killed by a signal
  int signal = 0;
  double seconds = 0;               // wall time
  std::vector<std::string> head;    // the first output lines
  std::vector<std::string> tail;    // the last output lines
  bool ok() const { return !signaled && exit_code == 0; }
  // "exit code 1" / "killed by signal 9", then the last output lines.
  std::string Describe() const;
};

// Runs `colmap <args...>`; output lines go to the log at debug level. Throws UserError when it cannot start.
ColmapToolRun RunColmapTool(const std::vector<std::string>& args);
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
