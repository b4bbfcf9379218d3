// Options of the `report` stage: the self-contained HTML report.
#pragma once

#include <string>

#include "core/error.h"
#include "core/options.h"
#include "core/stage.h"

namespace relight {

inline const StageInfo kReportStage{
    "report",
    "HTML report: cameras and geometry, photos beside re-renderings, environment maps, materials, relit views, charts",
    8};

struct ReportOptions {
  std::string title;               // page title; empty: "relight report: <workspace name>"
  std::string charts = "gnuplot";  // gnuplot (SVG charts drawn from the CSV beside them) or none (CSV only)
  int max_photos = 32;             // photos shown with images (evenly spread); tables list all; 0: all
  int tile_px = 220;               // display width of image tiles in the page [CSS px]

  void Declare(OptionTable* t) {
    t->Add("title", &title, "Page title; empty: 'relight report: <workspace name>'.");
    t->Add("charts", &charts,
           "Charts: gnuplot (SVG drawn by the gnuplot program from the CSV files beside them; Debian gnuplot-nox) "
           "or none (CSV files only).")
        .Choices({"gnuplot", "none"});
    t->Add("max_photos", &max_photos,
           "Photos shown with images (evenly spread over the collection); tables list every photo; 0: all.")
        .Min(0);
    t->Add("tile_px", &tile_px, "Display width of an image tile in the page (CSS pixels).").Range(64, 2048);
  }
  void Check() const {}
};

}  // namespace relight
