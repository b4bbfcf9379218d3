#include "pipeline/runner.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <set>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/timer.h"
#include "pipeline/interrupt.h"
#include "pipeline/slurm.h"
#include "pipeline/subprocess.h"

namespace relight::pipeline {
namespace fs = std::filesystem;

namespace {

std::string NowIso() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%S", std::localtime(&t));
  return buf;
}

std::string ShortKey(const std::string& key) { return key.substr(0, 16); }

// Appends `text` to a log file (created if missing); a lost line is no reason to fail a run.
void AppendToFile(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::app | std::ios::binary) << text;
}

// Replaces `link` by a symlink to `target` atomically.
void UpdateSymlink(const std::string& target, const std::string& link) {
  std::error_code ec;
  const std::string tmp = link + std::string(kTempMarker) + std::to_string(::getpid());
  fs::remove(tmp, ec);
  fs::create_directory_symlink(target, tmp, ec);
  if (ec) return;  // symlinks are a convenience; never fail a run over them
  fs::rename(tmp, link, ec);
  if (ec) fs::remove(tmp, ec);
}

}  // namespace

Runner::Runner(const std::vector<StageDef>& stages, const ResolvedConfig& config, std::string workspace,
               std::string bin_dir)
    : stages_(stages),
      config_(config),
      workspace_(fs::absolute(workspace).lexically_normal().string()),
      bin_dir_(std::move(bin_dir)),
      digests_(JoinPath(workspace_, "cache/input_digests.json")) {}

const StageDef& Runner::Def(const std::string& name) const {
  for (const auto& s : stages_)
    if (s.name() == name) return s;
  RELIGHT_CHECK(false) << "no stage " << name;
  return stages_.front();
}

void Runner::CheckStageName(const std::string& name, const std::string& flag) const {
  if (name.empty()) return;
  for (const auto& s : stages_)
    if (s.name() == name) return;
  std::string names;
  for (const auto& s : stages_) names += (names.empty() ? "" : ", ") + s.name();
  RELIGHT_USER_ERROR() << flag << " " << name << ": no such stage; stages: " << names;
}

std::string Runner::EntryDir(const std::string& stage, const std::string& key) const {
  return JoinPath(workspace_, "cache/" + stage + "/" + key);
}

bool Runner::IsDone(const std::string& dir, const std::string& key) {
  const std::string status = JoinPath(dir, "status.json");
  if (!fs::is_regular_file(status)) return false;
  try {
    const Json j = ReadJsonFile(status);
    return j.value("status", "") == "done" && j.value("key", "") == key;
  } catch (const std::exception&) {
    return false;
  }
}

std::vector<StageRecord> Runner::Plan() {
  std::vector<StageRecord> records;
  std::map<std::string, std::string> keys;  // stage -> key (non-skipped)
  for (const StageDef& def : stages_) {
    StageRecord r;
    r.name = def.name();
    if (def.skip_reason) {
      if (auto reason = def.skip_reason(config_)) {
        r.status = "skipped";
        r.reason = *reason;
        records.push_back(r);
        continue;
      }
    }
    std::string text = "stage=" + def.name() + "\nversion=" + std::to_string(def.info.version) + "\n";
    text += config_.options(def.name()).table().CanonicalText(
        [this](const std::string& path, const FileSelection& selection) { return digests_.Digest(path, selection); });
    for (const auto& up : def.upstream) {
      auto it = keys.find(up);
      if (it == keys.end()) continue;
      r.upstream[up] = it->second;
      text += "upstream " + up + "=" + it->second + "\n";
    }
    r.canonical = text;
    r.key = Sha256Hex(text);
    keys[def.name()] = r.key;
    r.output_dir = EntryDir(def.name(), r.key);
    if (IsDone(r.output_dir, r.key)) {
      r.status = "cached";
      try {
        const Json status = ReadJsonFile(JoinPath(r.output_dir, "status.json"));
        r.seconds = status.value("seconds", 0.0);
        r.peak_memory_mib = status.value("peak_memory_mib", 0.0);
      } catch (const std::exception&) {
      }
    } else {
      r.status = "missing";
    }
    records.push_back(r);
  }
  digests_.Save();
  return records;
}

std::vector<StageRecord> Runner::Run(const RunRequest& request) {
  CheckStageName(request.from, "--from");
  CheckStageName(request.only, "--only");
  CheckStageName(request.until, "--until");
  for (const auto& f : request.force) CheckStageName(f, "--force");
  EnsureDir(JoinPath(workspace_, "cache"));
  EnsureDir(JoinPath(workspace_, "stages"));

  std::vector<StageRecord> records = Plan();
  auto index_of = [&](const std::string& name) {
    for (size_t i = 0; i < records.size(); ++i)
      if (records[i].name == name) return static_cast<int>(i);
    return -1;
  };
  const int from = request.from.empty() ? -1 : index_of(request.from);
  const int until = request.until.empty() ? static_cast<int>(records.size()) - 1 : index_of(request.until);
  const int only = request.only.empty() ? -1 : index_of(request.only);
  if (from >= 0 && from > until) RELIGHT_USER_ERROR() << "--from " << request.from << " comes after --until " << request.until;
  for (int i : {from, only}) {
    if (i >= 0 && records[i].status == "skipped") {
      RELIGHT_USER_ERROR() << "stage '" << records[i].name << "' does not run for this config: " << records[i].reason;
    }
  }

  bool failed = false;
  bool interrupted = false;
  // Stages that produced a result in this run. A cached entry downstream of
  // one was computed from the result it replaced (a forced rerun keeps the key,
  // and a rerun may differ: COLMAP's spatial and vocab_tree matchers are not
  // deterministic), so it reruns too, or is invalidated when this run does not
  // reach it.
  std::set<std::string> produced;
  for (int i = 0; i < static_cast<int>(records.size()); ++i) {
    StageRecord& r = records[i];
    const bool done = r.status == "cached";
    std::string rerun_upstream;
    for (const auto& [up, key] : r.upstream) {
      if (produced.count(up) > 0) rerun_upstream = up;
    }
    if (r.status == "skipped") {
      WriteSummary(records);
      continue;
    }
    if (failed) {
      r.status = "skipped";
      r.reason = "an earlier stage failed";
      continue;
    }
    if (interrupted || InterruptSignal() != 0) {
      interrupted = true;
      r.status = "skipped";
      r.reason = "not reached: the run was interrupted";
      continue;
    }
    const bool selected = only >= 0 ? i == only : i <= until;
    if (!selected && done && !rerun_upstream.empty()) {
      std::error_code ec;
      fs::remove(JoinPath(r.output_dir, "status.json"), ec);
      r.status = "stale";
      r.reason = "'" + rerun_upstream + "' was rerun; the next run without --until/--only reruns it";
      RLOG_WARN("{}: cached result invalidated ({})", r.name, r.reason);
      produced.insert(r.name);
      continue;
    }
    if (!selected) {
      if (done) {
        Publish(r);
      } else {
        r.status = "skipped";
        r.reason = only >= 0 ? "--only " + request.only : "after --until " + request.until;
      }
      continue;
    }
    const bool force = request.force.count(r.name) > 0 || (from >= 0 && i >= from) || i == only ||
                       !rerun_upstream.empty();
    if (done && !force) {
      RLOG_INFO("{}: cached ({})", r.name, ShortKey(r.key));
      Publish(r);
      continue;
    }
    // Every upstream must have a finished result now.
    for (const auto& [up, key] : r.upstream) {
      if (!IsDone(EntryDir(up, key), key)) {
        RELIGHT_USER_ERROR() << "stage '" << r.name << "' needs the result of '" << up
                             << "', which is not in the cache; run `pipeline run CONFIG --until " << up
                             << "` first";
      }
    }
    r.status = "running";  // what summary.json says if `pipeline` itself is killed (kill -9)
    WriteSummary(records);
    const bool ok = RunOne(&r, done);
    WriteSummary(records);
    if (r.status == "interrupted") {
      interrupted = true;
      continue;
    }
    if (!ok) {
      failed = true;
      continue;
    }
    produced.insert(r.name);
    Publish(r);
  }
  WriteSummary(records);
  return records;
}

bool Runner::RunOne(StageRecord* r, bool replace_existing) {
  const StageDef& def = Def(r->name);
  // A forced rerun of a finished entry runs beside it and replaces it only on
  // success, so a failed or killed rerun never loses the earlier result.
  const std::string final_dir = r->output_dir;
  const std::string run_dir = replace_existing ? final_dir + ".rerun" : final_dir;
  const std::string log_path = JoinPath(run_dir, "stage.log");
  std::error_code ec;
  std::string earlier_log;  // the log of an earlier, unfinished rerun: kept at the top of the new one
  if (replace_existing) {
    if (fs::is_regular_file(log_path, ec)) earlier_log = ReadFileToString(log_path);
    fs::remove_all(run_dir, ec);
  }
  EnsureDir(run_dir);
  fs::remove(JoinPath(run_dir, "status.json"), ec);
  fs::remove(JoinPath(run_dir, "error.txt"), ec);

  const unsigned long long free_bytes = FreeBytes(run_dir);
  const double min_free = config_.pipeline().min_free_gib * 1024.0 * 1024.0 * 1024.0;
  if (free_bytes > 0 && static_cast<double>(free_bytes) < min_free) {
    RLOG_WARN("only {:.2f} GiB free on the workspace disk ({}); stage '{}' may run out of space",
              static_cast<double>(free_bytes) / (1024.0 * 1024.0 * 1024.0), workspace_, r->name);
  }

  // The fully resolved options of this stage, which the executable reads back.
  YAML::Node root;
  root[r->name] = config_.options(r->name).table().ToYaml();
  YAML::Emitter out;
  out << root;
  const std::string config_path = JoinPath(run_dir, "config.yaml");
  WriteFileAtomic(config_path, "# resolved options of stage " + r->name + " (key " + r->key + ")\n# from " +
                                   config_.document().path() + "\n" + out.c_str() + "\n");
  WriteFileAtomic(JoinPath(run_dir, "key.txt"), r->canonical);

  std::vector<std::string> argv{JoinPath(bin_dir_, def.ExecutableName()), "--config", config_path, "--output",
                                run_dir};
  for (const auto& [up, key] : r->upstream) argv.push_back("--input=" + up + "=" + EntryDir(up, key));
  const PipelineOptions& pipeline = config_.pipeline();
  const bool on_slurm = pipeline.executor == "slurm";
  argv.push_back("--threads=" + std::to_string(on_slurm ? pipeline.slurm_cpus_per_task : pipeline.threads));

  RLOG_INFO("{}: running ({})", r->name, ShortKey(r->key));
  const std::string started = NowIso();
  // The stage appends to its log; a resumed or repeated run shows where each attempt began.
  AppendToFile(log_path, earlier_log + "==== " + started + " pipeline: " + (earlier_log.empty() ? "" : "new ") +
                             "run of stage " + r->name + " (key " + ShortKey(r->key) + ") ====\n");
  Timer timer;
  ProcessResult result;
  if (on_slurm) {
    SlurmStageWork work;
    work.stage = r->name;
    work.argv = argv;
    work.output_dir = run_dir;
    work.shard_steps = def.shard_steps ? def.shard_steps(config_) : 0;
    SlurmOptions slurm;
    slurm.shards = pipeline.slurm_shards;
    slurm.cpus_per_task = pipeline.slurm_cpus_per_task;
    slurm.sbatch_args = pipeline.slurm_sbatch_args;
    result = RunOnSlurm(work, slurm);  // peak memory is not measured on the cluster
  } else {
    result = RunStageExecutable(argv);
  }
  r->seconds = timer.Seconds();
  r->peak_memory_mib = result.peak_memory_mib;
  if (!result.ok() && InterruptSignal() != 0) {
    r->status = "interrupted";
    r->reason = std::string("interrupted by SIG") + sigabbrev_np(InterruptSignal()) + " after " +
                Progress::FormatSeconds(r->seconds) +
                (replace_existing ? "; the earlier result is kept until a rerun finishes"
                                  : "; the next run resumes it in the same folder");
    AppendToFile(log_path, "==== " + NowIso() + " pipeline: " + r->reason + " ====\n");
    RLOG_WARN("{}: {}", r->name, r->reason);
    return false;
  }
  if (!result.ok()) {
    r->status = "failed";
    std::string reason;
    try {
      reason = ReadFileToString(JoinPath(run_dir, "error.txt"));
      while (!reason.empty() && (reason.back() == '\n' || reason.back() == '\r')) reason.pop_back();
    } catch (const UserError&) {
    }
    if (reason.empty()) {
      reason = result.Describe();  // crashed or killed: the stage wrote no reason
      RLOG_ERROR("stage '{}' failed: {}; log: {}", r->name, reason, log_path);
    } else {
      // The stage printed its reason itself; the console gets it once more at the end of the run.
      RLOG_ERROR("stage '{}' failed ({}); log: {}", r->name, result.Describe(), log_path);
      LogFileOnly("stage '" + r->name + "' failed: " + reason);
    }
    r->reason = reason;
    return false;
  }
  OrderedJson status;
  status["stage"] = r->name;
  status["status"] = "done";
  status["key"] = r->key;
  status["version"] = def.info.version;
  status["seconds"] = r->seconds;
  status["peak_memory_mib"] = r->peak_memory_mib;
  status["started"] = started;
  status["finished"] = NowIso();
  status["upstream"] = r->upstream;
  WriteJsonAtomic(JoinPath(run_dir, "status.json"), status);
  if (replace_existing) ReplaceDir(run_dir, final_dir);
  r->status = "done";
  RLOG_INFO("{}: done in {}", r->name, Progress::FormatSeconds(r->seconds));
  return true;
}

void Runner::Publish(const StageRecord& r) {
  UpdateSymlink("../cache/" + r.name + "/" + r.key, JoinPath(workspace_, "stages/" + r.name));
  if (r.name == "report") UpdateSymlink("cache/report/" + r.key, JoinPath(workspace_, "report"));
}

void Runner::WriteSummary(const std::vector<StageRecord>& records) const {
  OrderedJson j;
  j["config"] = config_.document().path();
  j["workspace"] = workspace_;
  j["written"] = NowIso();
  OrderedJson stages = OrderedJson::array();
  for (const auto& r : records) {
    OrderedJson s;
    s["name"] = r.name;
    s["key"] = r.key;
    s["status"] = r.status == "missing" ? "skipped" : r.status;
    s["seconds"] = r.status == "cached" ? 0.0 : r.seconds;
    const bool ran = r.status == "done" || r.status == "failed" || r.status == "interrupted";
    s["peak_memory_mib"] = ran ? r.peak_memory_mib : 0.0;  // like seconds: 0 for a cached stage
    s["output_dir"] = r.output_dir;
    if (!r.reason.empty()) s["reason"] = r.reason;
    stages.push_back(s);
  }
  j["stages"] = stages;
  WriteJsonAtomic(JoinPath(workspace_, "summary.json"), j);
}

int Runner::Clean(bool keep_latest) {
  std::set<std::string> keep;
  if (keep_latest) {
    for (const auto& r : Plan())
      if (!r.key.empty()) keep.insert(r.name + "/" + r.key);
  }
  int removed = 0;
  const std::string cache = JoinPath(workspace_, "cache");
  std::error_code ec;
  if (!fs::is_directory(cache)) return 0;
  for (const auto& stage_dir : fs::directory_iterator(cache)) {
    if (!stage_dir.is_directory()) continue;
    for (const auto& entry : fs::directory_iterator(stage_dir.path())) {
      const std::string id = stage_dir.path().filename().string() + "/" + entry.path().filename().string();
      if (keep.count(id)) continue;
      fs::remove_all(entry.path(), ec);
      ++removed;
    }
  }
  if (!keep_latest) {
    fs::remove_all(JoinPath(workspace_, "stages"), ec);
    fs::remove(JoinPath(workspace_, "report"), ec);
    fs::remove(JoinPath(workspace_, "summary.json"), ec);
  }
  return removed;
}

WorkspaceLock::WorkspaceLock(const std::string& workspace) {
  EnsureDir(workspace);
  const std::string path = JoinPath(workspace, ".lock");
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) RELIGHT_USER_ERROR() << "cannot open lock file '" << path << "': " << std::strerror(errno);
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd_);
    fd_ = -1;
    RELIGHT_USER_ERROR() << "another `pipeline` is using workspace '" << workspace
                         << "'; wait for it to finish or use --workspace";
  }
}

WorkspaceLock::~WorkspaceLock() {
  if (fd_ >= 0) ::close(fd_);
}

}  // namespace relight::pipeline
