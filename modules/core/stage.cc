#include "core/stage.h"

#include <tbb/global_control.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <memory>
#include <thread>

#include "core/fs.h"
#include "core/log.h"
#include "core/path_text.h"

namespace relight {
namespace fs = std::filesystem;

const std::string& StageContext::Input(const std::string& name) const {
  auto it = inputs.find(name);
  if (it == inputs.end()) {
    RELIGHT_USER_ERROR() << "this stage needs the output of stage '" << name << "': pass --input " << name
                         << "=DIR (the pipeline does this for you)";
  }
  return it->second;
}

std::string ShardSpec::Describe() const {
  return "step " + std::to_string(step) + ", shard " + std::to_string(index) + " of " + std::to_string(count);
}

std::string StageContext::OutputPath(const std::string& relative) const { return JoinPath(output_dir, relative); }

namespace internal {

void LogBriefReport(const std::string& report) { RLOG_INFO("{}", report); }

int RunStageProgram(int argc, char** argv, const StageInfo& info, OptionTable* table,
                    const std::function<void()>& check, const StageRunFn& run) {
  CLI::App app(info.name + ": " + info.description, info.name);
  std::string config_path, output_dir, log_level = "info", print_options;
  std::vector<std::string> sets, inputs;
  int threads = 0;
  std::string shard_text;
  int step = 0;
  app.add_option("--config", config_path, "YAML config; this stage reads its '" + info.name + "' section");
  app.add_option("--set", sets, "Override an option: " + info.name + ".OPTION=VALUE (repeatable)");
  app.add_option("--input", inputs, "Upstream stage output: STAGE=DIR (repeatable)");
  app.add_option("--output", output_dir, "Folder to write the outputs into (created if missing)");
  app.add_option("--threads", threads, "Worker threads; 0 uses all cores")->check(CLI::NonNegativeNumber);
  if (info.shardable) {
    app.add_option("--shard", shard_text,
                   "I/N: do only the per-photo work of items with index % N == I (0-based), and only of --step; "
                   "an unsharded run afterwards writes the stage's summaries (the pipeline's slurm executor)");
    app.add_option("--step", step, "Pass of the per-photo work a --shard run does (0-based)")
        ->check(CLI::NonNegativeNumber);
  }
  app.add_option("--log-level", log_level, "Console log level")
      ->check(CLI::IsMember({"debug", "info", "warning", "error"}));
  app.add_option("--print-options", print_options, "Print the option reference and exit")
      ->check(CLI::IsMember({"markdown", "text"}));
  app.footer("\n" + table->HelpText() + "\nExit codes: 0 success, 2 bad input (reason in OUTPUT/error.txt), "
             "3 internal error.");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kExitOk : kExitUserError;  // --help is 0; CLI11's own codes (106, ...) mean nothing here
  }
  if (!print_options.empty()) {
    std::cout << (print_options == "markdown" ? table->MarkdownReference() : table->HelpText());
    return kExitOk;
  }

  StageContext ctx;
  ctx.threads = threads;
  if (!shard_text.empty()) {
    const size_t slash = shard_text.find('/');
    // Both numbers whole: "1x/4" or "1/4.5" is not a shard.
    const auto parse = [](const std::string& text, int* value) {
      size_t used = 0;
      try {
        *value = std::stoi(text, &used);
      } catch (const std::exception&) {
        return false;
      }
      return used == text.size();
    };
    if (slash == std::string::npos || !parse(shard_text.substr(0, slash), &ctx.shard.index) ||
        !parse(shard_text.substr(slash + 1), &ctx.shard.count)) {
      ctx.shard.count = 0;
    }
    if (ctx.shard.count <= 0 || ctx.shard.index < 0 || ctx.shard.index >= ctx.shard.count) {
      std::cerr << info.name << ": error: --shard '" << shard_text << "': expected I/N with 0 <= I < N\n";
      return kExitUserError;
    }
    ctx.shard.step = step;
  }
  // Shards run at the same time in one folder: each reports and logs under shards/, and none may remove what
  // another is writing (temporary files, error.txt).
  const std::string shard_stem =
      ctx.shard.active() ? "shards/step" + std::to_string(ctx.shard.step) + "_" + std::to_string(ctx.shard.index) : "";
  const std::string error_name = ctx.shard.active() ? shard_stem + ".error.txt" : "error.txt";
  const std::string log_name = ctx.shard.active() ? shard_stem + ".log" : "stage.log";
  auto fail = [&](int code, const std::string& raw_reason) {
    const std::string reason = PathText(raw_reason);
    // One line, for the orchestrator's summary and the user.
    if (!ctx.output_dir.empty()) {
      try {
        WriteFileAtomic(JoinPath(ctx.output_dir, error_name), reason + "\n");
      } catch (...) {
      }
    }
    if (spdlog::default_logger()) {
      RLOG_ERROR("{}", reason);
      FlushLogs();
    } else {
      std::cerr << info.name << ": error: " << reason << "\n";
    }
    return code;
  };

  try {
    if (output_dir.empty()) {
      std::cerr << info.name << ": error: --output DIR is required (see --help)\n";
      return kExitUserError;
    }
    ctx.output_dir = fs::absolute(output_dir).lexically_normal().string();
    EnsureDir(ctx.output_dir);
    if (ctx.shard.active()) {
      EnsureDir(JoinPath(ctx.output_dir, "shards"));
    } else {
      RemoveTempFiles(ctx.output_dir);
    }
    std::error_code ec;
    fs::remove(JoinPath(ctx.output_dir, error_name), ec);
    InitLogging(info.name, JoinPath(ctx.output_dir, log_name), ParseLogLevel(log_level));
    InstallCrashHandler(info.name, JoinPath(ctx.output_dir, log_name));
    if (ctx.shard.active()) RLOG_INFO("{}: {}", info.name, ctx.shard.Describe());

    for (const auto& input : inputs) {
      const size_t eq = input.find('=');
      if (eq == std::string::npos) RELIGHT_USER_ERROR() << "--input '" << input << "': expected STAGE=DIR";
      const std::string dir = fs::absolute(input.substr(eq + 1)).lexically_normal().string();
      if (!fs::is_directory(dir)) {
        RELIGHT_USER_ERROR() << "--input " << input.substr(0, eq) << ": folder '" << dir << "' does not exist";
      }
      ctx.inputs[input.substr(0, eq)] = dir;
    }

    ConfigDocument config = config_path.empty() ? ConfigDocument::Empty() : ConfigDocument::Load(config_path);
    for (const auto& s : sets) config.AddOverride(s);
    config.Apply(table);
    check();
    for (const std::string& name : table->ExperimentalInUse()) {
      RLOG_WARN("{} is a measurement switch (for tests and docs/RESULTS.md), not for production runs", name);
    }

    // The resolved options, unless we were started from exactly that file.
    const std::string resolved = JoinPath(ctx.output_dir, "config.yaml");
    if (config_path.empty() || fs::absolute(config_path).lexically_normal() != fs::path(resolved)) {
      YAML::Emitter out;
      YAML::Node root;
      root[info.name] = table->ToYaml();
      out << root;
      WriteFileAtomic(resolved, std::string("# resolved options of stage ") + info.name + "\n" + out.c_str() + "\n");
    }

    const int hw = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    ctx.threads = threads > 0 ? threads : hw;
    tbb::global_control parallelism(tbb::global_control::max_allowed_parallelism,
                                    static_cast<size_t>(ctx.threads));
    RLOG_DEBUG("stage {} v{} output {} threads {}", info.name, info.version, ctx.output_dir, ctx.threads);
    run(ctx);
    FlushLogs();
    return kExitOk;
  } catch (const UserError& e) {
    return fail(kExitUserError, e.what());
  } catch (const InternalError& e) {
    return fail(kExitInternalError, std::string("internal error (please report it): ") + e.what());
  } catch (const std::bad_alloc&) {
    return fail(kExitUserError, "out of memory; lower the resolution options or the number of photos");
  } catch (const std::exception& e) {
    return fail(kExitInternalError, std::string("internal error (please report it): ") + e.what());
  }
}

}  // namespace internal
}  // namespace relight
