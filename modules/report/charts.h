// Charts of the report: every chart is a CSV file of its data, a gnuplot
// script beside it, and the SVG the script draws (Debian gnuplot-nox, run as a
// program). Regenerate one by hand with `gnuplot <name>.gp` in the charts
// folder; other tools (sweeps) can plot the same CSV files.
#pragma once

#include <string>
#include <vector>

namespace relight {

// What WriteChart produced.
struct ChartFiles {
  std::string csv;  // file names, relative to the chart folder
  std::string script;
  std::string svg;    // empty when not drawn
  std::string error;  // why the SVG was not drawn (gnuplot missing or failed)
};

// Writes <dir>/<name>.csv (header `columns`, then `rows`; write "NaN" for missing values) and
// <dir>/<name>.gp, whose plot commands are `body` (it may refer to the data as '<name>.csv', skipping the
// header with `skip 1`); with `draw`, runs gnuplot to make <dir>/<name>.svg (written atomically).
ChartFiles WriteChart(const std::string& dir, const std::string& name, const std::vector<std::string>& columns,
                      const std::vector<std::vector<std::string>>& rows, const std::string& body, bool draw,
                      int width_px = 640, int height_px = 360);

// Runs `gnuplot <args...>` in folder `dir`; returns "" on success, else what went wrong (including the
// program's error output).
std::string RunGnuplot(const std::string& dir, const std::vector<std::string>& args);

// A CSV field: quoted when it holds a comma, quote or newline.
std::string CsvField(const std::string& text);

}  // namespace relight
