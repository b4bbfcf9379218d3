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

std::string StageContext::OutputPath(const std::string& relative) const { return JoinPath(output_dir, relative); }

namespace internal {

int RunStageProgram(int argc, char** argv, const StageInfo& info, OptionTable* table,
                    const std::function<void()>& check, const StageRunFn& run) {
  CLI::App app(info.name + ": " + info.description, info.name);
  std::string config_path, output_dir, log_level = "info", print_options;
  std::vector<std::string> sets, inputs;
  int threads = 0;
  app.add_option("--config", config_path, "YAML config; this stage reads its '" + info.name + "' section");
  app.add_option("--set", sets, "Override an option: " + info.name + ".OPTION=VALUE (repeatable)");
  app.add_option("--input", inputs, "Upstream stage output: STAGE=DIR (repeatable)");
  app.add_option("--output", output_dir, "Folder to write the outputs into (created if missing)");
  app.add_option("--threads", threads, "Worker threads; 0 uses all cores")->check(CLI::NonNegativeNumber);
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
  auto fail = [&](int code, const std::string& raw_reason) {
    const std::string reason = PathText(raw_reason);
    // One line, for the orchestrator's summary and the user.
    if (!ctx.output_dir.empty()) {
      try {
        WriteFileAtomic(JoinPath(ctx.output_dir, "error.txt"), reason + "\n");
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
    RemoveTempFiles(ctx.output_dir);
    std::error_code ec;
    fs::remove(JoinPath(ctx.output_dir, "error.txt"), ec);
    InitLogging(info.name, JoinPath(ctx.output_dir, "stage.log"), ParseLogLevel(log_level));
    InstallCrashHandler(info.name, JoinPath(ctx.output_dir, "stage.log"));

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
