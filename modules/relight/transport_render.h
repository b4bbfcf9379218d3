// Noise-free relighting of the recovered model by the method's own forward
// model (Haber et al. 2009, eqs. 2 and 7): the exit radiance of vertex v
// towards w_o is
//     B_v(w_o) = Σ_b k_{v,b} Σ_j V_v(ω_j) f_b(ω_j, w_o) cos θ_j Ω_j L(R_v ω_j),
// summed over the texels ω_j of the vertex's hemi-octahedral visibility map
// (the `visibility` stage's, sub-sampled as the inverse stage's transport rows
// are, solver/transport.h), with L the light filtered to the octahedral map of
// the inverse stage's resolution and read bilinearly: the same numbers the
// solver fitted the photos with, evaluated for any view and any light. Delta
// lights (directional, point) add f cos E at each vertex that a shadow ray
// finds unblocked; so does a sun sharper than a texel of the filtered map,
// split out of a lat-long light first (render/sun_light.h), so that a sunny
// HDR map casts sharp shadows here too. Pixels interpolate the radiance of the hit triangle's
// vertices (Gouraud shading, the barycentric weights of the ray hit); each
// pixel averages a regular k×k grid of camera rays. The Monte Carlo renderer
// (render/render_view.h) stays the reference: it shades every ray hit with the
// full-resolution light, so a sun sharper than a texel of the filtered map
// casts sharper shadows and highlights there.
//
// Lambertian lobes use each vertex's transport row, built once per vertex as the inverse stage builds its
// rows (solver/transport.h): Σ_j V_j cos θ_j Ω_j splatted bilinearly onto the global map, here from 64²
// directions per hemisphere (each visibility texel's value held), Haar-transformed and truncated to the
// coefficients holding 99.9 % of its energy (at most 256); a light then costs one sparse dot product per
// vertex with its Haar coefficients.
//
// With EnableInterreflection, one bounce of light between the object's own vertices (visibility/bounce.h),
// as the inverse stage solves with `inverse.interreflection` (solver/interreflection.h), is added to the
// object's Lambertian lobes:
//     B_v(w_o) += Σ_{b Lambertian} k_{v,b} Σ_s w_s D_{h_s},   D_h = Σ_{b Lambertian} k_{h,b} E_h / π,
// with (h_s, w_s) the vertices v sees along its blocked directions and their cosine weights, and D_h the
// diffuse exit radiance of vertex h under the light's direct part (its Lambertian row as above, plus the
// delta lights and the split-out sun where h's shadow ray is unblocked). When asked, occluder vertices the
// object sees send theirs too (in the albedo the inverse stage recovered), but receive none. The light
// a hit vertex's glossy lobes reflect is left out, and glossy lobes receive no bounce. D
// is needed at every object vertex (any vertex can be hit), so a light's first use decodes the maps and
// builds the Lambertian rows of all object vertices (kept, as for the vertices views see: a byte per
// visibility texel) and casts their shadow rays; the gathered bounce is then kept per light.
//
// Glossy lobes are summed by adaptive quadrature: over a half-resolution map whose texels average four
// visibility texels, except where a lobe is above 1 % of its peak (its core, widened by a texel), which keeps
// the visibility map's own texels. A lobe at least three coarse texels wide (GGX/Beckmann α ≥ about 0.25 on
// 32² maps) has no core. The tails are smooth, so the coarse texels integrate them within about 1 % for
// lights no sharper than the filtered map, at a fraction of the work.
//
// Occluders (surfaces of role kOccluder, grey Lambertian) have no visibility
// maps from the `visibility` stage: the vertices a view needs get theirs baked
// on first use (visibility/visibility.h, kOccluderVisibilityResolution) and
// kept for later views. View-independent parts (Lambertian sums, shadow-ray
// results, the bounce) are kept per light, so a turntable or a second view under the same
// light costs only the glossy lobes. The cost of a view grows with the
// vertices it sees (the glossy sums), Monte Carlo's with its pixels × samples.
//
// Hand-written: Embree (geometry/raycaster.h) casts the rays, but no library
// evaluates per-vertex precomputed radiance transport against our visibility
// maps and basis BRDFs.
#pragma once

#include <Eigen/Core>
#include <map>
#include <memory>
#include <vector>

#include "core/progress.h"
#include "geometry/camera.h"
#include "geometry/reconstruction.h"
#include "render/lighting.h"
#include "render/render_view.h"
#include "render/scene.h"
#include "visibility/bounce.h"
#include "visibility/visibility.h"

namespace relight {

// Side of the hemi-octahedral visibility maps baked for occluder vertices.
inline constexpr int kOccluderVisibilityResolution = 16;

struct TransportRenderOptions {
  int pixel_samples_per_axis = 2;  // a regular k x k grid of camera rays per pixel (box filter)
  bool background = true;          // rays that miss every surface show the environment (else black)
  int band_rows = 32;              // image rows cast and shaded together (bounds memory on large photos)
};

// What TransportRenderer::EnableInterreflection computed.
struct InterreflectionSummary {
  size_t num_samples = 0;  // (vertex, vertex it sees) pairs over the object's vertices
  double seconds = 0;      // time of ComputeBounceSamples
};

class TransportRenderer {
 public:
  // `scene`: surface 0 the object, whose vertices are those of `object_visibility`; other surfaces are
  // occluders. `env_resolution`: side of the octahedral map environment light is filtered to (the inverse
  // stage's `env_resolution`, lighting.json). Both must outlive the renderer.
  TransportRenderer(const Scene& scene, const VisibilityData& object_visibility, int env_resolution);
  ~TransportRenderer();
  TransportRenderer(const TransportRenderer&) = delete;
  TransportRenderer& operator=(const TransportRenderer&) = delete;

  // Renders `pose` through `camera` under `lighting`. Work kept for a light is found by the Lighting's
  // address: pass the same object for views that share a light. The returned view's `radiance`, `mask`
  // (pixel-centre ray hits the object), `coverage`, `depth` and `surface` follow render/render_view.h.
  RenderedView Render(const Lighting& lighting, const Camera& camera, const ImageRecord& pose,
                      const TransportRenderOptions& options, Progress* progress = nullptr);

  // Exit radiance of vertex `vertex` of surface `surface` towards world direction `dir_out_world`
  // (unit, away from the surface) under `lighting`: the value Render interpolates.
  Eigen::Vector3f VertexRadiance(const Lighting& lighting, int surface, int vertex,
                                 const Eigen::Vector3f& dir_out_world);

  // Adds one bounce between the object's vertices (file comment), its samples cast against the whole scene
  // (occluders block); with `occluders_bounce` the occluders (surface 1) send their diffuse light too. Call
  // before rendering: the work kept for lights so far is dropped.
  InterreflectionSummary EnableInterreflection(const BounceOptions& options, bool occluders_bounce);
  bool interreflection() const { return interreflection_; }
  // The object's bounce samples (visibility/bounce.h) when interreflection() is on.
  const BounceSamples& object_bounce() const { return bounce_; }

  // Progress units Render advances for a camera (its bands of rows).
  static int64_t NumBands(const Camera& camera, const TransportRenderOptions& options);

  // Drops what is kept for `lighting` (after its last view).
  void Forget(const Lighting& lighting);

  // Builds the Lambertian rows (file comment) of every object vertex that lacks one, on all threads. Render
  // builds what a view needs on the way; after this it only reads them, so other threads may read rows with
  // ObjectRow while views render.
  void BuildObjectRows();
  // Object vertex `vertex`'s Lambertian row: its kept Haar coefficients of the env_resolution² global map,
  // ascending indices, without the 1/π (Σ_j V_j Ω_j cos θ_j: the irradiance weights). Valid until the renderer
  // is destroyed; BuildObjectRows first.
  struct Row {
    const uint16_t* index = nullptr;
    const float* value = nullptr;
    uint32_t size = 0;
  };
  Row ObjectRow(uint32_t vertex) const;
  int env_resolution() const { return env_resolution_; }

 private:
  struct TexelTable;
  struct CoarseTable;
  struct LightState;
  struct SurfaceState;

  LightState& Prepare(const Lighting& lighting);
  // The bounce each object vertex receives under `light` (LightState::bounce_in), from every object vertex's
  // diffuse exit radiance.
  void PrepareBounce(LightState* light);
  // D_h of `vertices` of `surface` under `light` (RGB per vertex of the surface; others 0).
  std::vector<float> DiffuseExit(LightState* light, int surface, const std::vector<uint32_t>& vertices);
  // The env part of the Lambertian lobes' radiance of `vertex` (summed albedo `lambert_rgb`), kept per light.
  const Eigen::Vector3f& DiffuseEnv(LightState* light, int surface, uint32_t vertex,
                                    const Eigen::Vector3f& lambert_rgb);
  // Calls fn(to_light_world, cos_i, irradiance_rgb) for each delta light above the shading normal
  // `normal_world` of `vertex` whose shadow ray is unblocked (the ray's result kept per light).
  template <typename Fn>
  void ForEachUnblockedDelta(LightState* light, int surface, uint32_t vertex, const Eigen::Vector3f& normal_world,
                             Fn&& fn);
  // Fills `state`'s occluder visibility for the listed vertices that lack it.
  void EnsureOccluderVisibility(int surface, const std::vector<uint32_t>& vertices);
  Eigen::Vector3f Shade(const LightState& light, int surface, uint32_t vertex, const Eigen::Vector3f& dir_out_world);

  const Scene& scene_;
  const VisibilityData& object_visibility_;
  int env_resolution_;
  std::unique_ptr<TexelTable> object_texels_, occluder_texels_;          // glossy lobes, per view
  std::unique_ptr<TexelTable> object_row_texels_, occluder_row_texels_;  // Lambertian rows, once per vertex
  std::unique_ptr<CoarseTable> object_coarse_;  // glossy lobes' tails
  std::vector<std::unique_ptr<SurfaceState>> surfaces_;
  std::map<const Lighting*, std::unique_ptr<LightState>> lights_;
  bool interreflection_ = false;
  BounceSamples bounce_;                            // of the object's vertices, when interreflection_
  BounceSamples occluder_bounce_;                   // their samples on the occluders (surface 1)
  std::vector<uint32_t> occluder_bounce_vertices_;  // the occluder vertices those reach
  float ray_offset_ = 0;
  uint32_t views_rendered_ = 0;  // stamps of SurfaceState::view_stamp
};

}  // namespace relight
