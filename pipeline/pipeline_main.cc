// `pipeline`: chains the stage executables with a content-keyed cache.
//
//   pipeline run CONFIG [--workspace DIR] [--from STAGE] [--only STAGE] [--force STAGE] [--until STAGE]
//   pipeline status CONFIG        pipeline clean CONFIG [--keep-latest]
//   pipeline report CONFIG        pipeline stages        pipeline options [STAGE]
//   pipeline render CONFIG --cameras MODEL_DIR --envmap FILE [--envmap-convention C] [--rotate-deg R]
//                          [--strength S] --out DIR
#include <CLI/CLI.hpp>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/log.h"
#include "core/path_text.h"
#include "core/progress.h"
#include "pipeline/interrupt.h"
#include "pipeline/runner.h"
#include "pipeline/stage_graph.h"
#include "pipeline/subprocess.h"
#ifdef RELIGHT_HAVE_RELIGHT
#include "relight/relight_options.h"
#endif

namespace relight::pipeline {
namespace {
namespace fs = std::filesystem;

struct CommonArgs {
  std::string config;
  std::string workspace;
  std::vector<std::string> sets;
};

void AddCommon(CLI::App* cmd, CommonArgs* args) {
  cmd->add_option("CONFIG", args->config, "YAML config (see configs/README.md)")->required();
  cmd->add_option("--workspace", args->workspace,
                  "Workspace folder; default: pipeline.workspace from the config, else ./workspace/<config name>");
  cmd->add_option("--set", args->sets, "Override an option: STAGE.OPTION=VALUE (repeatable)");
}

std::string ResolveWorkspace(const CommonArgs& args, const ResolvedConfig& config) {
  if (!args.workspace.empty()) return fs::absolute(args.workspace).lexically_normal().string();
  if (!config.pipeline().workspace.empty()) return config.pipeline().workspace;
  return fs::absolute(fs::path("workspace") / config.document().stem()).lexically_normal().string();
}

ConfigDocument LoadDocument(const CommonArgs& args) {
  ConfigDocument doc = ConfigDocument::Load(args.config);
  for (const auto& s : args.sets) doc.AddOverride(s);
  return doc;
}

void PrintTable(const std::vector<StageRecord>& records, std::ostream& out) {
  out << std::left << std::setw(12) << "stage" << std::setw(12) << "status" << std::setw(10) << "seconds"
      << std::setw(10) << "peak MiB" << std::setw(18) << "key" << "output / reason\n";
  for (const auto& r : records) {
    std::ostringstream secs, memory;
    secs << std::fixed << std::setprecision(1) << r.seconds;
    memory << std::fixed << std::setprecision(0) << r.peak_memory_mib;
    // One line per stage: a long reason is cut here (it is printed in full below the table).
    std::string detail = PathText(r.reason.empty() ? r.output_dir : r.reason);
    if (!r.reason.empty() && detail.size() > 100) detail = detail.substr(0, 97) + "...";
    out << std::left << std::setw(12) << r.name << std::setw(12) << r.status << std::setw(10)
        << (r.key.empty() ? "-" : secs.str()) << std::setw(10)
        << (r.key.empty() || r.peak_memory_mib <= 0 ? "-" : memory.str()) << std::setw(18)
        << (r.key.empty() ? "-" : r.key.substr(0, 16)) << detail << "\n";
  }
}

// Quotes an argument for a shell command line when it needs it.
std::string ShellWord(const std::string& word) {
  if (!word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-+=.,/:@%") ==
                           std::string::npos) {
    return PathText(word);
  }
  std::string quoted = "'";
  for (char c : word) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return PathText(quoted + "'");
}

// The command that continues an interrupted run: same config, workspace and
// overrides; --from the interrupted stage when it had an earlier result (a
// rerun), else nothing (the stage resumes in its folder); --until/--only kept.
std::string ResumeCommand(const CommonArgs& args, const RunRequest& request, const StageRecord* interrupted,
                          bool report_only) {
  std::string cmd = std::string("pipeline ") + (report_only ? "report " : "run ") + ShellWord(args.config);
  if (!args.workspace.empty()) cmd += " --workspace " + ShellWord(args.workspace);
  for (const auto& s : args.sets) cmd += " --set " + ShellWord(s);
  if (interrupted != nullptr && fs::exists(JoinPath(interrupted->output_dir, "status.json")) &&
      request.only.empty()) {
    cmd += " --from " + interrupted->name;
  }
  if (!request.only.empty()) cmd += " --only " + request.only;
  if (!request.until.empty()) cmd += " --until " + request.until;
  return cmd;
}

int CmdRun(const CommonArgs& args, const RunRequest& request, bool report_only) {
  const ResolvedConfig config(LoadDocument(args), AllStages());
  const std::string workspace = ResolveWorkspace(args, config);
  WorkspaceLock lock(workspace);
  InitLogging("pipeline", JoinPath(workspace, "pipeline.log"), LogLevel::kInfo);
  InstallInterruptHandler();
  RLOG_INFO("config {}, workspace {}", config.document().path(), workspace);
  Runner runner(AllStages(), config, workspace, ExecutableDir());
  const auto records = runner.Run(request);
  std::cerr << "\n";
  PrintTable(records, std::cerr);
  if (const int sig = InterruptSignal()) {
    const StageRecord* stage = nullptr;
    for (const auto& r : records)
      if (r.status == "interrupted") stage = &r;
    const std::string what = stage != nullptr ? "stage '" + stage->name + "' was interrupted (" + stage->reason + ")"
                                              : std::string("the run was interrupted before a stage started");
    const std::string resume = ResumeCommand(args, request, stage, report_only);
    RLOG_WARN("{}; finished stages are cached; to resume: {}", what, resume);
    std::cerr << "pipeline: " << what << "\n"
              << "pipeline: finished stages are cached; to resume: " << resume << "\n";
    if (stage != nullptr) std::cerr << "pipeline: log: " << JoinPath(stage->output_dir, "stage.log") << "\n";
    FlushLogs();
    return 128 + sig;
  }
  for (const auto& r : records) {
    if (r.status == "failed") {
      std::cerr << "pipeline: stage '" << r.name << "' failed: " << PathText(r.reason) << "\n"
                << "pipeline: log: " << JoinPath(r.output_dir.empty() ? workspace : r.output_dir, "stage.log")
                << "\n";
      return 1;
    }
  }
  std::cerr << "summary: " << JoinPath(workspace, "summary.json") << "\n";
  const std::string report = JoinPath(workspace, "report/index.html");
  if (fs::exists(report)) std::cerr << "report: " << report << "\n";
  if (report_only && !fs::exists(report)) {
    std::cerr << "pipeline: no report was written (is the report stage enabled?)\n";
    return 1;
  }
  return 0;
}

// What `pipeline render` passes on to `render_cameras` (pipeline/render_cameras_main.cc).
struct RenderArgs {
  std::string cameras, envmap, convention = "relight", out, renderer;
  double rotate_deg = 0, strength = 1;
  int max_size = 0;
};

// Runs the stages the model needs (up to inverse; cached ones are reused), then `render_cameras` on them.
int CmdRender(const CommonArgs& args, const RenderArgs& render) {
  int code = CmdRun(args, RunRequest{"", "", "inverse", {}}, false);
  if (code != 0) return code;
  const ResolvedConfig config(LoadDocument(args), AllStages());
  const std::string workspace = ResolveWorkspace(args, config);
  InitLogging("pipeline", JoinPath(workspace, "pipeline.log"), LogLevel::kInfo);
  Runner runner(AllStages(), config, workspace, ExecutableDir());
  std::map<std::string, std::string> dirs;
  for (const StageRecord& r : runner.Plan())
    if (r.status == "cached") dirs[r.name] = r.output_dir;
  if (!dirs.count("inverse")) RELIGHT_USER_ERROR() << "the inverse stage has no result for this config";
  std::string renderer = render.renderer;
  double occluder_albedo = 0.35;
#ifdef RELIGHT_HAVE_RELIGHT
  const RelightOptions& relight = config.Get<RelightOptions>("relight");
  if (renderer.empty()) renderer = relight.renderer;
  occluder_albedo = relight.occluder_albedo;
#endif
  if (renderer.empty()) renderer = "transport";
  std::vector<std::string> argv{JoinPath(ExecutableDir(), "render_cameras"),
                                "--inverse", dirs["inverse"],
                                "--cameras", render.cameras,
                                "--envmap", render.envmap,
                                "--envmap-convention", render.convention,
                                "--rotate-deg", std::to_string(render.rotate_deg),
                                "--strength", std::to_string(render.strength),
                                "--out", render.out,
                                "--renderer", renderer,
                                "--max-size", std::to_string(render.max_size),
                                "--occluder-albedo", std::to_string(occluder_albedo)};
  if (dirs.count("mesh")) argv.insert(argv.end(), {"--mesh", dirs["mesh"]});
  if (dirs.count("visibility")) argv.insert(argv.end(), {"--visibility", dirs["visibility"]});
  RLOG_INFO("render: {}", [&] {
    std::string line;
    for (const auto& a : argv) line += ShellWord(a) + " ";
    return line;
  }());
  const ProcessResult result = RunStageExecutable(argv);
  if (!result.ok()) {
    std::cerr << "pipeline: render_cameras failed (" << result.Describe() << ")\n";
    return result.signaled ? 128 + result.signal : (result.exit_code == kExitUserError ? kExitUserError : 1);
  }
  std::cerr << "render: " << JoinPath(render.out, "render_summary.json") << "\n";
  return 0;
}

int CmdStatus(const CommonArgs& args) {
  const ResolvedConfig config(LoadDocument(args), AllStages());
  const std::string workspace = ResolveWorkspace(args, config);
  InitLogging("pipeline", "", LogLevel::kWarning);
  Runner runner(AllStages(), config, workspace, ExecutableDir());
  std::cout << "workspace " << workspace << "\n";
  PrintTable(runner.Plan(), std::cout);
  return 0;
}

int CmdClean(const CommonArgs& args, bool keep_latest) {
  const ResolvedConfig config(LoadDocument(args), AllStages());
  const std::string workspace = ResolveWorkspace(args, config);
  if (!fs::exists(workspace)) {
    std::cout << "nothing to clean: " << workspace << " does not exist\n";
    return 0;
  }
  WorkspaceLock lock(workspace);
  InitLogging("pipeline", "", LogLevel::kWarning);
  Runner runner(AllStages(), config, workspace, ExecutableDir());
  const int removed = runner.Clean(keep_latest);
  std::cout << "removed " << removed << " cache entr" << (removed == 1 ? "y" : "ies") << " from " << workspace
            << (keep_latest ? " (kept the entries of the current config)" : "") << "\n";
  return 0;
}

int CmdStages() {
  for (const auto& s : AllStages()) {
    std::cout << std::left << std::setw(12) << s.name() << s.info.description << "\n";
  }
  return 0;
}

int CmdOptions(const std::string& stage, bool markdown) {
  PipelineOptions pipeline_options;
  OptionTable pipeline_table = MakeOptionTable("pipeline", &pipeline_options);
  std::string experimental_rows = pipeline_table.MarkdownExperimentalRows();
  if (stage.empty() || stage == "pipeline") {
    std::cout << (markdown ? "### pipeline\n\nThe orchestrator itself.\n\n" + pipeline_table.MarkdownReference() + "\n"
                           : pipeline_table.HelpText() + "\n");
  }
  bool found = stage.empty() || stage == "pipeline";
  for (const auto& s : AllStages()) {
    if (!stage.empty() && s.name() != stage) continue;
    found = true;
    auto holder = s.make_options();
    if (markdown) {
      std::cout << "### " << s.name() << "\n\n" << s.info.description << "\n\n"
                << holder->table().MarkdownReference() << "\n";
      experimental_rows += holder->table().MarkdownExperimentalRows();
    } else {
      std::cout << s.name() << ": " << s.info.description << "\n" << holder->table().HelpText() << "\n";
    }
  }
  if (!found) RELIGHT_USER_ERROR() << "no stage named '" << stage << "'; see `pipeline stages`";
  // Measurement switches close the whole reference (or a stage's, with STAGE), apart from the user's tables.
  if (markdown && !experimental_rows.empty()) {
    std::cout << "### Measurement switches (for tests and docs/RESULTS.md; not for production runs)\n\n"
              << "Ground truth fed into a stage, or a superseded method kept to compare against. A stage run "
                 "with one of them away from its default logs a warning.\n\n"
              << "| key | type | default | allowed | description |\n|---|---|---|---|---|\n"
              << experimental_rows << "\n";
  }
  return 0;
}

int Main(int argc, char** argv) {
  CLI::App app("relight pipeline: relightable 3D models from photo collections", "pipeline");
  app.require_subcommand(1);
  CommonArgs common;
  RunRequest request;
  std::vector<std::string> force;

  auto* run = app.add_subcommand("run", "Run every stage that is not cached for CONFIG");
  AddCommon(run, &common);
  run->add_option("--from", request.from, "Rerun this stage and every later one");
  run->add_option("--only", request.only, "Run only this stage (its upstream must be cached)");
  run->add_option("--force", force, "Rerun this stage even if cached, and the stages downstream of it (repeatable)");
  run->add_option("--until", request.until, "Stop after this stage");

  auto* status = app.add_subcommand("status", "Show which stages of CONFIG are cached");
  AddCommon(status, &common);
  bool keep_latest = false;
  auto* clean = app.add_subcommand("clean", "Delete cache entries of CONFIG's workspace");
  AddCommon(clean, &common);
  clean->add_flag("--keep-latest", keep_latest, "Keep the entries the current config uses");
  auto* report = app.add_subcommand("report", "Run what is needed and write <workspace>/report/index.html");
  AddCommon(report, &common);
  RenderArgs render_args;
  auto* render = app.add_subcommand(
      "render", "Run what the model needs, then render it from COLMAP cameras under an environment map");
  AddCommon(render, &common);
  render->add_option("--cameras", render_args.cameras, "COLMAP model folder (cameras, images) in the model's frame, "
                                                       "e.g. <workspace>/stages/sfm/sparse")
      ->required();
  render->add_option("--envmap", render_args.envmap, "The light: lat-long (2:1) or octahedral (square) .exr/.hdr")
      ->required();
  render->add_option("--envmap-convention", render_args.convention,
                     "How the map's columns name directions: relight, blender (Cycles' world) or mitsuba "
                     "(Mitsuba 3 envmap, +Y up); docs/FORMATS.md")
      ->capture_default_str();
  render->add_option("--rotate-deg", render_args.rotate_deg, "Turn the light about +Z, from +X towards +Y [deg]")
      ->capture_default_str();
  render->add_option("--strength", render_args.strength, "Scale of the light's radiance")->capture_default_str();
  render->add_option("--out", render_args.out, "Output folder")->required();
  render->add_option("--renderer", render_args.renderer, "transport or monte_carlo (default: relight.renderer)");
  render->add_option("--max-size", render_args.max_size, "Longer image side in pixels (0: the cameras' sizes)")
      ->capture_default_str();
  app.add_subcommand("stages", "List the stages with one-line descriptions");
  std::string options_stage;
  bool markdown = false;
  auto* options = app.add_subcommand("options", "Print the option reference (all stages, or one)");
  options->add_option("STAGE", options_stage, "Stage name (or 'pipeline')");
  options->add_flag("--markdown", markdown, "Markdown tables (as in configs/README.md)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : kExitUserError;  // --help is 0; CLI11's own codes (106, ...) mean nothing here
  }
  try {
    if (run->parsed()) {
      request.force.insert(force.begin(), force.end());
      return CmdRun(common, request, false);
    }
    if (report->parsed()) return CmdRun(common, RunRequest{}, true);
    if (render->parsed()) return CmdRender(common, render_args);
    if (status->parsed()) return CmdStatus(common);
    if (clean->parsed()) return CmdClean(common, keep_latest);
    if (options->parsed()) return CmdOptions(options_stage, markdown);
    return CmdStages();
  } catch (const UserError& e) {
    std::cerr << "pipeline: error: " << PathText(e.what()) << "\n";
    return kExitUserError;
  } catch (const std::exception& e) {
    std::cerr << "pipeline: internal error (please report it): " << PathText(e.what()) << "\n";
    return kExitInternalError;
  }
}

}  // namespace
}  // namespace relight::pipeline

int main(int argc, char** argv) { return relight::pipeline::Main(argc, argv); }
