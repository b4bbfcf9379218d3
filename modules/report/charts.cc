#include "report/charts.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "core/fs.h"

extern char** environ;

namespace relight {
namespace fs = std::filesystem;

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string RunGnuplot(const std::string& dir, const std::vector<std::string>& args) {
  const std::string log = JoinPath(dir, "gnuplot.log");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addchdir_np(&actions, dir.c_str());
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<std::string> argv_s{"gnuplot"};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, "gnuplot", &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    return std::string("cannot run gnuplot (") + std::strerror(rc) +
           "); install Debian's gnuplot-nox (tools/setup_debian.sh) for the charts";
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  std::string output;
  try {
    output = ReadFileToString(log);
  } catch (...) {
  }
  std::error_code ec;
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
    fs::remove(log, ec);
    return "";
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 127) {
    return "gnuplot is not installed; install Debian's gnuplot-nox (tools/setup_debian.sh) for the charts";
  }
  while (!output.empty() && (output.back() == '\n' || output.back() == '\r')) output.pop_back();
  return "gnuplot failed: " + output;
}

ChartFiles WriteChart(const std::string& dir, const std::string& name, const std::vector<std::string>& columns,
                      const std::vector<std::vector<std::string>>& rows, const std::string& body, bool draw,
                      int width_px, int height_px) {
  ChartFiles files;
  files.csv = name + ".csv";
  files.script = name + ".gp";
  std::ostringstream csv;
  for (size_t k = 0; k < columns.size(); ++k) csv << (k ? "," : "") << CsvField(columns[k]);
  csv << "\n";
  for (const auto& row : rows) {
    for (size_t k = 0; k < row.size(); ++k) csv << (k ? "," : "") << CsvField(row[k]);
    csv << "\n";
  }
  WriteFileAtomic(JoinPath(dir, files.csv), csv.str());
  std::ostringstream gp;
  gp << "# Draws " << name << ".svg from " << name << ".csv: gnuplot " << name << ".gp\n"
     << "if (!exists(\"out\")) out = '" << name << ".svg'\n"
     << "set terminal svg size " << width_px << "," << height_px << " font 'sans,11' background '#ffffff'\n"
     << "set output out\n"
     << "set datafile separator ','\n"
     << "set datafile missing 'NaN'\n"
     << "set grid ytics lc rgb '#dddddd'\n"
     << body << "\n";
  WriteFileAtomic(JoinPath(dir, files.script), gp.str());
  if (!draw) return files;
  const std::string temp = name + std::string(kTempMarker) + "gnuplot.svg";
  files.error = RunGnuplot(dir, {"-e", "out='" + temp + "'", files.script});
  std::error_code ec;
  if (files.error.empty() && fs::is_regular_file(JoinPath(dir, temp)) && fs::file_size(JoinPath(dir, temp), ec) > 0) {
    fs::rename(JoinPath(dir, temp), JoinPath(dir, name + ".svg"), ec);
    if (!ec)
      files.svg = name + ".svg";
    else
      files.error = "cannot rename the chart: " + ec.message();
  } else if (files.error.empty()) {
    files.error = "gnuplot wrote no " + name + ".svg";
  }
  fs::remove(JoinPath(dir, temp), ec);
  return files;
}

}  // namespace relight
