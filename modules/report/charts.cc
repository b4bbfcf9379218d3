#include "report/charts.h"

#include <filesystem>
#include <sstream>

#include "core/fs.h"
#include "core/process.h"

namespace relight {
namespace fs = std::filesystem;

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string RunGnuplot(const std::string& dir, const std::vector<std::string>& args) {
  std::vector<std::string> argv{"gnuplot"};
  argv.insert(argv.end(), args.begin(), args.end());
  ProcessOptions options;
  options.output = ProcessOptions::Output::kLines;
  options.working_dir = dir;
  const ProcessResult run = RunProcess(argv, options);
  if (!run.started()) {
    return run.start_error + "; install Debian's gnuplot-nox (tools/setup_debian.sh) for the charts";
  }
  if (run.ok()) return "";
  return "gnuplot failed (" + run.DescribeWithOutput(8) + ")";
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
