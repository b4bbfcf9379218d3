// The interactive relighting viewer (issue 36): <dir>/viewer.html, a self-contained WebGL 2 page, and
// <dir>/viewer_data.js, its assets (docs/FORMATS.md, "Viewer"). The page relights the recovered model in
// real time under each given map, turned about +Z by a slider, from an orbit camera.
//
// What the page computes per vertex v seen from world direction w_o (all linear radiance):
//   diffuse  ρ_v,diffuse ⊙ (T_v · H(L_θ))   T_v: the vertex's Lambertian transport row in the Haar basis of
//            the env_resolution² octahedral map, exactly the transport renderer's (relight/transport_render.h),
//            truncated to its top_k largest coefficients; H(L_θ) the Haar transform of
//            the map turned by θ about +Z, resampled at the texel centres (bilinear, in the page);
//   glossy   Σ_b ρ_v,b ⊙ A_b(cos_o) · P_b(R_z(−θ) r) · V_v(r) for every non-Lambertian lobe b (split-sum
//            approximation, Karis 2013): r the mirror of w_o about the normal; P_b the map prefiltered with
//            the lobe's shape around r (Phong n: max(0, w·r)^n; GGX and Beckmann α: Phong about r with
//            n = max(1, (2/α² − 2)/4), the half-vector lobe of Walter et al. 2007 widened twice in angle),
//            normalised to integrate to 1, so a constant map is exact; A_b(cos_o) = ∫ f_b cos dω the lobe's
//            directional albedo; V_v(r) the vertex's visibility averaged to a glossy_visibility² hemi-
//            octahedral map, read bilinearly at r. Exact are: no visibility inside the lobe's footprint but
//            at its axis, and the lobe's true shape (its cosine, horizon and Fresnel are in A_b only).
//   bounce   with the bounce the model was solved with (RecoveredModel::bounce_rays_per_side): the diffuse
//            term of every vertex plus ρ_v,diffuse ⊙ Σ_s w_s D_s, D_s the diffuse term of the vertices it sees
//            (visibility/bounce.h; the occluders block, their own bounce is left out).
// Then exposure and the sRGB curve (relight/display.h): by default the exposure maps the tonemap_percentile
// of the vertices' luminance under the selected map to 1 (relight's PNGs take it over pixels); an
// `exposure` URL parameter sets it. Shading is per vertex and interpolated over the triangles (Gouraud).
// The per-vertex work runs in JavaScript (typed arrays, about 16 ms for 50K vertices with three lobes), the
// diffuse part only when the light changes. WebGL draws in two passes: a camera change rasterises the
// triangles into a visibility buffer (triangle and barycentrics per pixel), and every frame interpolates the
// vertex colours per pixel from it, so a light change costs no triangle drawing (which dominates a frame on a
// software rasteriser such as SwiftShader when triangles are about as many as pixels).
//
// Written by hand: no library relights precomputed wavelet transport in a browser.
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "relight/relight.h"
#include "relight/transport_render.h"
#include "sphere/envmap.h"
#include "visibility/visibility.h"

namespace relight {

struct ViewerOptions {
  int top_k = 64;                   // Haar coefficients kept per vertex of the diffuse transport (largest first)
  int env_resolution = 32;          // side of the octahedral maps the page relights with (power of two)
  int glossy_resolution = 64;       // side of the prefiltered glossy maps (power of two)
  int glossy_visibility = 4;        // side of the per-vertex hemi-octahedral visibility the glossy term reads
  int albedo_table_size = 32;       // entries of each glossy lobe's directional-albedo table over cos_o in [0, 1]
  double tonemap_percentile = 99;   // default exposure: this percentile of vertex luminance maps to 1

  // Throws UserError naming the option that is out of range.
  void Check() const;
};

// What WriteViewerAssets wrote.
struct ViewerExport {
  std::string html;                // absolute path of viewer.html
  std::string data;                // absolute path of viewer_data.js
  size_t num_vertices = 0;
  int top_k = 0;
  int num_maps = 0;
  size_t data_bytes = 0;
  double seconds = 0;

  // One line for the log.
  std::string BriefReport() const;
};

// Writes viewer.html and viewer_data.js into `dir` (created when missing), each atomically. `visibility`
// holds one map per vertex of model.mesh (which needs normals); `transport` renders the model (its object
// surface model.mesh, env_resolution options.env_resolution), holds every vertex's row
// (TransportRenderer::BuildObjectRows), which the page's diffuse term takes, and the model's bounce
// (EnableModelInterreflection), which the page gathers; `maps` are (name, map) pairs shown in the
// page's selector in this order: an octahedral map of env_resolution side without rotation or scaling is
// taken texel for texel, any other is resampled to texel averages as the transport renderer does
// (EnvMap::ToOctahedral, EnvMap::CoveringSupersampling).
ViewerExport WriteViewerAssets(const std::string& dir, const RecoveredModel& model, const VisibilityData& visibility,
                               const TransportRenderer& transport,
                               const std::vector<std::pair<std::string, EnvMap>>& maps, const ViewerOptions& options);

// The page's orbit camera (URL parameters az, el, dist, fov; docs/FORMATS.md): it looks at `center` from
// center + dist_factor · radius · (cos el cos az, cos el sin az, sin el), world +Z up on the screen, with a
// vertical field of view of fov_deg over the canvas height and square pixels.
struct ViewerCamera {
  Eigen::Vector3d eye_world, center_world;
  double fov_y_deg = 40;
  int width = 640, height = 480;

  // Unit world direction of the ray through the centre of pixel (x, y) (row 0 at the top).
  Eigen::Vector3d PixelRay(int x, int y) const;
};
ViewerCamera ViewerOrbitCamera(const Eigen::Vector3d& center_world, double radius, double azimuth_deg,
                               double elevation_deg, double dist_factor, double fov_y_deg, int width, int height);

}  // namespace relight
