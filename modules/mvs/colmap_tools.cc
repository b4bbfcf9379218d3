#include "mvs/colmap_tools.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/timer.h"
#include "geometry/mesh_io.h"

namespace relight {
namespace fs = std::filesystem;

std::string ColmapToolRun::Describe() const {
  std::ostringstream s;
  if (signaled) {
    s << "killed by signal " << signal;
  } else {
    s << "exit code " << exit_code;
  }
  if (!tail.empty()) {
    s << ": ";
    const size_t first = tail.size() > 4 ? tail.size() - 4 : 0;
    for (size_t i = first; i < tail.size(); ++i) s << (i > first ? " | " : "") << tail[i];
  }
  return s.str();
}

ColmapToolRun RunColmapTool(const std::vector<std::string>& args) {
  std::vector<std::string> argv_strings = {ColmapExecutable()};
  argv_strings.insert(argv_strings.end(), args.begin(), args.end());
  std::string command_line;
  for (const auto& a : argv_strings) command_line += (command_line.empty() ? "" : " ") + a;
  RLOG_DEBUG("running {}", command_line);

  // Everything the child needs is allocated before fork (a forked child of a threaded process must not malloc).
  std::vector<char*> argv;
  for (auto& a : argv_strings) argv.push_back(a.data());
  argv.push_back(nullptr);
  // COLMAP's OpenMP loops spin while waiting by default, which starves everything on a shared machine.
  std::vector<std::string> env_strings;
  for (char** e = environ; *e != nullptr; ++e) env_strings.emplace_back(*e);
  if (std::getenv("OMP_WAIT_POLICY") == nullptr) env_strings.emplace_back("OMP_WAIT_POLICY=passive");
  std::vector<char*> envp;
  for (auto& e : env_strings) envp.push_back(e.data());
  envp.push_back(nullptr);
  const std::string exec_error = "cannot execute " + argv_strings[0] + "\n";

  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) RELIGHT_USER_ERROR() << "cannot create a pipe to run COLMAP: " << strerror(errno);
  const pid_t parent = getpid();
  Timer timer;
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    RELIGHT_USER_ERROR() << "cannot start COLMAP (fork failed: " << strerror(errno) << ")";
  }
  if (pid == 0) {
    // Child: die with the stage; merged stdout/stderr into the pipe.
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (getppid() != parent) _exit(127);
    dup2(fds[1], STDOUT_FILENO);
    dup2(fds[1], STDERR_FILENO);
    const int devnull = open("/dev/null", O_RDONLY);
    if (devnull >= 0) dup2(devnull, STDIN_FILENO);
    execvpe(argv[0], argv.data(), envp.data());
    (void)!write(STDERR_FILENO, exec_error.data(), exec_error.size());
    _exit(127);
  }
  close(fds[1]);
  ColmapToolRun run;
  std::deque<std::string> tail;
  std::string pending;
  char buffer[4096];
  const auto flush_line = [&](std::string line) {
    while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
    if (line.empty()) return;
    LogFileOnly("colmap: " + line);
    if (run.head.size() < 10) run.head.push_back(line);
    tail.push_back(std::move(line));
    if (tail.size() > 20) tail.pop_front();
  };
  while (true) {
    const ssize_t got = read(fds[0], buffer, sizeof(buffer));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) break;
    pending.append(buffer, size_t(got));
    size_t pos;
    while ((pos = pending.find('\n')) != std::string::npos) {
      flush_line(pending.substr(0, pos));
      pending.erase(0, pos + 1);
    }
  }
  flush_line(pending);
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  run.seconds = timer.Seconds();
  run.tail.assign(tail.begin(), tail.end());
  if (WIFSIGNALED(status)) {
    run.signaled = true;
    run.signal = WTERMSIG(status);
  } else {
    run.exit_code = WEXITSTATUS(status);
  }
  if (run.exit_code == 127 && !run.tail.empty() && run.tail.back().rfind("cannot execute", 0) == 0) {
    RELIGHT_USER_ERROR() << run.tail.back() << ": install COLMAP (apt-get install colmap) or set RELIGHT_COLMAP "
                         << "to its path";
  }
  RLOG_DEBUG("colmap {} finished in {:.1f}s ({})", args.empty() ? "" : args[0], run.seconds, run.Describe());
  return run;
}

bool ColmapHasCuda(std::string* banner) {
  const ColmapToolRun run = RunColmapTool({"help"});
  // "COLMAP 3.8 -- Structure-from-Motion ..." then "(Commit ... on ... without CUDA)" / "with CUDA".
  bool cuda = false;
  std::string version;
  for (const auto& line : run.head) {
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
  const ColmapToolRun run = RunColmapTool({"stereo_fusion",
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
    RELIGHT_USER_ERROR() << "colmap stereo_fusion failed on '" << workspace_dir << "' (" << run.Describe()
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
  const ColmapToolRun run = RunColmapTool({"poisson_mesher",
                                           "--input_path", fused_ply,
                                           "--output_path", out.temp_path(),
                                           "--PoissonMeshing.depth", std::to_string(options.poisson_depth),
                                           "--PoissonMeshing.trim", std::to_string(options.poisson_trim),
                                           "--PoissonMeshing.num_threads", "1"});  // deterministic (colmap_tools.h)
  if (!run.ok() || !fs::exists(out.temp_path())) {
    RELIGHT_USER_ERROR() << "colmap poisson_mesher wrote no mesh from '" << fused_ply << "' (" << run.Describe()
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
  const ColmapToolRun run =
      RunColmapTool({"patch_match_stereo", "--workspace_path", workspace_dir, "--workspace_format", "COLMAP",
                     "--PatchMatchStereo.geom_consistency", options.geom_consistency ? "true" : "false",
                     "--PatchMatchStereo.max_image_size", std::to_string(options.max_image_size > 0 ? options.max_image_size : -1),
                     "--PatchMatchStereo.window_radius", std::to_string(options.window_radius),
                     "--PatchMatchStereo.window_step", std::to_string(options.window_step),
                     "--PatchMatchStereo.num_iterations", std::to_string(options.num_iterations),
                     "--PatchMatchStereo.filter_min_ncc", std::to_string(options.filter_min_ncc),
                     "--PatchMatchStereo.filter_min_num_consistent", std::to_string(options.filter_min_num_consistent)});
  if (!run.ok()) {
    RELIGHT_USER_ERROR() << "colmap patch_match_stereo failed on '" << workspace_dir << "' (" << run.Describe()
                         << "); see stage.log";
  }
}

}  // namespace relight
