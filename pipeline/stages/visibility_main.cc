// Stage executable `visibility` (see modules/visibility/visibility.h).
#include "visibility/visibility.h"

int main(int argc, char** argv) {
  using namespace relight;
  return StageMain<VisibilityOptions>(argc, argv, kVisibilityStage,
                                      [](const VisibilityOptions& options, const StageContext& ctx) {
                                        return RunVisibility(options, {ctx.Input("mesh")}, ctx.output_dir);
                                      });
}
