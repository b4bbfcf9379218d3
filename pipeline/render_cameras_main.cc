// `render_cameras`: renders the recovered model from a COLMAP camera model under one environment map
// (modules/relight/render_cameras.h). `pipeline render CONFIG ...` runs the stages it needs and then this
// program on their outputs; it can also be run directly on the folders of a workspace.
#include <CLI/CLI.hpp>
#include <iostream>

#include "core/error.h"
#include "core/log.h"
#include "core/stage.h"
#include "relight/render_cameras.h"

int main(int argc, char** argv) {
  using namespace relight;
  CLI::App app("Render the recovered model from COLMAP cameras under an environment map", "render_cameras");
  RenderCamerasRequest r;
  std::string convention = "relight";
  app.add_option("--inverse", r.inverse_dir, "The inverse stage's folder (reflectance.ply, materials.json)")
      ->required();
  app.add_option("--mesh", r.mesh_dir, "The mesh stage's folder (occluders.ply); optional");
  app.add_option("--visibility", r.visibility_dir, "The visibility stage's folder (visibility.bin)");
  app.add_option("--cameras", r.cameras_dir, "COLMAP model folder (cameras, images) in the model's frame")
      ->required();
  app.add_option("--envmap", r.envmap, "The light: a lat-long (2:1) or octahedral (square) .exr/.hdr map")
      ->required();
  app.add_option("--envmap-convention", convention, "How the map's columns name directions: relight, blender or "
                                                    "mitsuba (docs/FORMATS.md)")
      ->capture_default_str();
  app.add_option("--rotate-deg", r.rotate_deg, "Turn the light about +Z by this angle, from +X towards +Y [deg]")
      ->capture_default_str();
  app.add_option("--strength", r.strength, "Scale of the light's radiance")->capture_default_str();
  app.add_option("--out", r.output_dir, "Output folder: <image>.exr/.png/_mask.png, render_summary.json")
      ->required();
  app.add_option("--renderer", r.renderer, "transport (noise-free, from the model's transport) or monte_carlo")
      ->capture_default_str();
  app.add_option("--max-size", r.max_size, "Longer image side; larger cameras are scaled down (0: their size)")
      ->capture_default_str();
  app.add_option("--pixel-samples", r.pixel_samples_per_axis, "k x k camera rays per pixel")->capture_default_str();
  app.add_option("--occluder-albedo", r.occluder_albedo, "Grey albedo of the mesh stage's occluders")
      ->capture_default_str();
  bool no_background = false;
  app.add_flag("--no-background", no_background, "Black where no surface is hit (else the map)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : kExitUserError;
  }
  InitLogging("render_cameras", "", LogLevel::kInfo);
  try {
    r.convention = ParseEnvmapConvention(convention);
    r.background = !no_background;
    const RenderCamerasSummary summary = RenderCameras(r);
    RLOG_INFO("render: {}; {}", summary.BriefReport(), r.output_dir);
    return kExitOk;
  } catch (const UserError& e) {
    std::cerr << "render_cameras: error: " << e.what() << "\n";
    return kExitUserError;
  } catch (const std::exception& e) {
    std::cerr << "render_cameras: internal error (please report it): " << e.what() << "\n";
    return kExitInternalError;
  }
}
