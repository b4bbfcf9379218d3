#include "relight/viewer_export.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "core/error.h"
#include "core/fs.h"
#include "core/json.h"
#include "observe/observations.h"
#include "render/scene.h"
#include "sphere/octahedral.h"
#include "visibility/bounce.h"

namespace relight {
namespace {

// Standard base64 (RFC 4648) of raw bytes; the page decodes it with atob().
std::string Base64(const void* data, size_t size) {
  static const char kTable[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* p = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < size; i += 3) {
    const uint32_t v = (uint32_t(p[i]) << 16) | (uint32_t(p[i + 1]) << 8) | p[i + 2];
    for (int s = 18; s >= 0; s -= 6) out.push_back(kTable[(v >> s) & 63]);
  }
  if (i < size) {
    const uint32_t v = (uint32_t(p[i]) << 16) | (i + 1 < size ? uint32_t(p[i + 1]) << 8 : 0);
    out.push_back(kTable[(v >> 18) & 63]);
    out.push_back(kTable[(v >> 12) & 63]);
    out.push_back(i + 1 < size ? kTable[(v >> 6) & 63] : '=');
    out.push_back('=');
  }
  return out;
}

// Named little-endian arrays of viewer_data.js (x86 and ARM hosts are little-endian, as are all browsers' typed
// arrays in practice; docs/FORMATS.md).
struct Buffers {
  OrderedJson index = OrderedJson::object();  // name -> {"type", "count"}
  std::string js;                              // "name": "base64", ...
  size_t bytes = 0;

  template <typename T>
  void Add(const std::string& name, const std::string& type, const std::vector<T>& values) {
    index[name] = {{"type", type}, {"count", values.size()}};
    js += (js.empty() ? "\n\"" : ",\n\"") + name + "\": \"" + Base64(values.data(), values.size() * sizeof(T)) + "\"";
    bytes += values.size() * sizeof(T);
  }
};

// Phong exponent of the viewer's reflection-space kernel of a glossy lobe (viewer_export.h).
double KernelExponent(const BrdfLobe& lobe) {
  if (lobe.model == BrdfModel::kPhong) return lobe.exponent;
  const double a = lobe.roughness;
  return std::max(1.0, (2.0 / (a * a) - 2.0) / 4.0);
}

// A_b(cos_o) = ∫ f_b(wi, wo) cos_i dωi at cos_o = t / (size − 1), by quadrature over 256² hemi-octahedral texels.
std::vector<float> DirectionalAlbedoTable(const BrdfLobe& lobe, int size) {
  constexpr int kQuadrature = 256;
  const std::vector<Eigen::Vector3d> dirs = HemiOctTexelDirections(kQuadrature);
  const std::vector<double> solid_angles = HemiOctTexelSolidAngles(kQuadrature);
  std::vector<float> table(size);
  tbb::parallel_for(0, size, [&](int t) {
    const double cos_o = double(t) / (size - 1);
    const Eigen::Vector3d wo(std::sqrt(std::max(0.0, 1 - cos_o * cos_o)), 0, cos_o);
    double sum = 0;
    for (size_t q = 0; q < dirs.size(); ++q) sum += lobe.Eval(dirs[q], wo) * dirs[q].z() * solid_angles[q];
    table[t] = static_cast<float>(sum);
  });
  return table;
}

// Prefiltering with max(0, w·r)^exponent (normalised) at the texel centres r of a side² octahedral map, from
// the texel centres of the map's own octahedral grid (its stored values). The weights depend on the geometry
// alone, so they are built once per lobe and applied to every map.
struct PrefilterKernel {
  std::vector<uint32_t> first;  // out texel t: entries [first[t], first[t + 1])
  std::vector<uint32_t> source;
  std::vector<float> weight;    // normalised per out texel

  PrefilterKernel(double exponent, int side, int source_side) {
    const std::vector<Eigen::Vector3d> src = OctTexelDirections(source_side);
    const std::vector<double> src_sr = OctTexelSolidAngles(source_side);
    const double cos_cut = std::pow(1e-6, 1.0 / exponent);  // kernel below 1e-6 of its peak is left out
    const std::vector<Eigen::Vector3d> out_dirs = OctTexelDirections(side);
    std::vector<std::vector<std::pair<uint32_t, float>>> rows(out_dirs.size());
    tbb::parallel_for(size_t(0), out_dirs.size(), [&](size_t t) {
      double total = 0;
      for (size_t q = 0; q < src.size(); ++q) {
        const double c = src[q].dot(out_dirs[t]);
        if (c <= cos_cut) continue;
        const double k = std::pow(c, exponent) * src_sr[q];
        rows[t].emplace_back(static_cast<uint32_t>(q), static_cast<float>(k));
        total += k;
      }
      for (auto& e : rows[t]) e.second = static_cast<float>(e.second / total);
    });
    first.push_back(0);
    for (const auto& row : rows) {
      for (const auto& [q, w] : row) {
        source.push_back(q);
        weight.push_back(w);
      }
      first.push_back(static_cast<uint32_t>(source.size()));
    }
  }

  // The prefiltered RGB values of an octahedral image of source_side (row-major texels).
  std::vector<float> Apply(const Image& oct) const {
    std::vector<float> out((first.size() - 1) * 3, 0.0f);
    tbb::parallel_for(size_t(0), first.size() - 1, [&](size_t t) {
      double sum[3] = {0, 0, 0};
      for (uint32_t e = first[t]; e < first[t + 1]; ++e)
        for (int c = 0; c < 3; ++c) sum[c] += weight[e] * oct.pixels[size_t(source[e]) * 3 + c];
      for (int c = 0; c < 3; ++c) out[t * 3 + c] = static_cast<float>(sum[c]);
    });
    return out;
  }
};

// The map as env_resolution² texel values (viewer_export.h: taken as is, or texel averages).
Image ViewerOctahedral(const EnvMap& map, int n) {
  if (map.layout() == EnvMap::Layout::kOctahedral && map.image().width == n && map.intensity() == 1.0 &&
      map.rotation_world().isIdentity(0.0))
    return map.image();
  return map.ToOctahedral(n, map.CoveringSupersampling(std::sqrt(4 * M_PI) / n));  // as the transport renderer
}

// The page (inline CSS and JavaScript, WebGL 2). Reads window.RELIGHT_VIEWER_DATA from viewer_data.js.
constexpr char kViewerHtml[] = R"HTML(<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>relight viewer</title>
<style>
body{margin:0;background:#111;color:#ddd;font:13px sans-serif}
#ui{padding:6px 8px;display:flex;flex-wrap:wrap;gap:6px 16px;align-items:center}
#ui label{display:flex;gap:6px;align-items:center}
canvas{display:block}
body.bare #ui,body.bare #status{display:none}
body.bare canvas{position:absolute;left:0;top:0}
#status{padding:4px 8px;color:#999}
</style></head>
<body>
<div id="ui">
<label>map <select id="map"></select></label>
<label>light about +Z <input id="rotate" type="range" min="0" max="360" step="1" value="0"><span id="rotate_v"></span></label>
<label>camera azimuth <input id="az" type="range" min="0" max="360" step="1" value="30"><span id="az_v"></span></label>
<label>elevation <input id="el" type="range" min="-10" max="89" step="1" value="20"><span id="el_v"></span></label>
<label>exposure (EV) <input id="ev" type="range" min="-6" max="6" step="0.1" value="0"><span id="ev_v"></span></label>
</div>
<canvas id="canvas"></canvas>
<div id="status" data-status="loading">loading</div>
<script src="viewer_data.js"></script>
<script>
'use strict';
const statusEl = document.getElementById('status');
function fail(msg) { statusEl.dataset.status = 'error'; statusEl.dataset.error = String(msg); statusEl.textContent = 'error: ' + msg; }
window.addEventListener('error', e => fail(e.message));
(function main() {
const D = window.RELIGHT_VIEWER_DATA;
if (!D || D.format !== 'relight-viewer' || D.version !== 1) { fail('viewer_data.js missing or of another version'); return; }
const M = D.meta;
function buf(name) {
  const s = atob(D.buffers[name]); const u = new Uint8Array(s.length);
  for (let i = 0; i < s.length; ++i) u[i] = s.charCodeAt(i);
  const T = {f32: Float32Array, u32: Uint32Array, u16: Uint16Array, i16: Int16Array, u8: Uint8Array}[D.index[name].type];
  return new T(u.buffer);
}
const P = new URLSearchParams(location.search);
const num = (k, d) => (P.has(k) && P.get(k) !== '' && isFinite(+P.get(k))) ? +P.get(k) : d;
const bare = P.get('bare') === '1';
if (bare) document.body.classList.add('bare');
const nv = M.num_vertices, K = M.top_k, n = M.env_resolution, gv = M.glossy_visibility, gr = M.glossy_resolution;
const pos = buf('positions'), nrm = buf('normals'), tri = buf('indices');
const dif = buf('diffuse_rgb'), tIdx = buf('transport_index'), tVal = buf('transport_value'), tScale = buf('transport_scale');
const lobes = M.glossy_lobes.map((l, b) => ({table: new Float32Array(l.albedo_table), rgb: buf('glossy_rgb_' + b)}));
const gVis = lobes.length ? buf('glossy_visibility') : null;
// Octahedral conventions of docs/FORMATS.md (sphere/octahedral.h).
const sgn = v => v >= 0 ? 1 : -1;
function octEncode(x, y, z, out) {
  const l1 = Math.abs(x) + Math.abs(y) + Math.abs(z); let px = x / l1, py = y / l1;
  if (z < 0) { const ox = px; px = (1 - Math.abs(py)) * sgn(ox); py = (1 - Math.abs(ox)) * sgn(py); }
  out[0] = px * 0.5 + 0.5; out[1] = py * 0.5 + 0.5;
}
function octDecode(s, t, out) {
  let x = s * 2 - 1, y = t * 2 - 1; const z = 1 - Math.abs(x) - Math.abs(y);
  if (z < 0) { const ox = x; x = (1 - Math.abs(y)) * sgn(ox); y = (1 - Math.abs(ox)) * sgn(y); }
  const l = Math.hypot(x, y, z); out[0] = x / l; out[1] = y / l; out[2] = z / l;
}
function octWrap(i, j, s) {  // OctWrapTexel
  if (i < 0) { i = -1 - i; j = s - 1 - j; } else if (i >= s) { i = 2 * s - 1 - i; j = s - 1 - j; }
  if (j < 0) { j = -1 - j; i = s - 1 - i; } else if (j >= s) { j = 2 * s - 1 - j; i = s - 1 - i; }
  return j * s + i;
}
// An s x s RGB map with a one-texel border of its fold neighbours, so bilinear reads need no branches.
function pad(src, s) {
  const p = s + 2, out = new Float32Array(p * p * 3);
  for (let j = -1; j <= s; ++j) for (let i = -1; i <= s; ++i) {
    const q = octWrap(i, j, s) * 3, o = ((j + 1) * p + i + 1) * 3;
    out[o] = src[q]; out[o + 1] = src[q + 1]; out[o + 2] = src[q + 2];
  }
  return out;
}
const st = new Float64Array(2);
// Bilinear reading of a padded s x s map at direction (x, y, z) into out[o..o+2] (EnvMap::Lookup).
function lookup(pm, s, x, y, z, out, o) {
  octEncode(x, y, z, st);
  const fx = st[0] * s - 0.5, fy = st[1] * s - 0.5, x0 = Math.floor(fx), y0 = Math.floor(fy);
  const ax = fx - x0, ay = fy - y0, p = s + 2, i00 = ((y0 + 1) * p + x0 + 1) * 3, i10 = i00 + 3, i01 = i00 + p * 3, i11 = i01 + 3;
  const w00 = (1 - ax) * (1 - ay), w10 = ax * (1 - ay), w01 = (1 - ax) * ay, w11 = ax * ay;
  for (let c = 0; c < 3; ++c) out[o + c] = w00 * pm[i00 + c] + w10 * pm[i10 + c] + w01 * pm[i01 + c] + w11 * pm[i11 + c];
}
// 2D non-standard orthonormal Haar transform in place (wavelet/haar.h HaarForward, same layout).
const haarTmp = new Float64Array(n * n);
function haarForward(a) {
  for (let size = n; size > 1; size >>= 1) {
    const half = size >> 1;
    for (let b = 0; b < half; ++b) {
      const r0 = 2 * b * n, r1 = r0 + n, avg = b * size, dy = (half + b) * size;
      for (let c = 0; c < half; ++c) {
        const p00 = a[r0 + 2 * c], p01 = a[r0 + 2 * c + 1], p10 = a[r1 + 2 * c], p11 = a[r1 + 2 * c + 1];
        haarTmp[avg + c] = 0.5 * (p00 + p01 + p10 + p11); haarTmp[avg + half + c] = 0.5 * (p00 - p01 + p10 - p11);
        haarTmp[dy + c] = 0.5 * (p00 + p01 - p10 - p11); haarTmp[dy + half + c] = 0.5 * (p00 - p01 - p10 + p11);
      }
    }
    for (let r = 0; r < size; ++r) for (let c = 0; c < size; ++c) a[r * n + c] = haarTmp[r * size + c];
  }
}
const texelDir = new Float64Array(n * n * 3);
for (let j = 0; j < n; ++j) for (let i = 0; i < n; ++i) {
  const d = [0, 0, 0]; octDecode((i + 0.5) / n, (j + 0.5) / n, d); texelDir.set(d, (j * n + i) * 3);
}
const maps = M.maps.map(m => ({name: m.name, oct: pad(buf(m.oct), n), pre: m.prefiltered.map(b => pad(buf(b), gr))}));
// Local frames (sphere/frame.h, Frisvad 2012) for the glossy visibility.
const frame = new Float32Array(nv * 6);
for (let v = 0; v < nv; ++v) {
  const x = nrm[3 * v], y = nrm[3 * v + 1], z = nrm[3 * v + 2];
  if (z < -0.9999999) { frame.set([0, -1, 0, -1, 0, 0], 6 * v); continue; }
  const a = 1 / (1 + z), b = -x * y * a;
  frame.set([1 - x * x * a, b, -x, b, 1 - y * y * a, -y], 6 * v);
}
// Light: the map turned by theta about +Z, resampled at the texel centres, Haar-transformed (RGB interleaved).
const plane = [new Float64Array(n * n), new Float64Array(n * n), new Float64Array(n * n)];
const lightHaar = new Float32Array(n * n * 3), rgb = new Float64Array(3);
function prepareLight(map, theta) {
  const c = Math.cos(theta), s = Math.sin(theta);
  for (let t = 0; t < n * n; ++t) {
    const x = texelDir[3 * t], y = texelDir[3 * t + 1], z = texelDir[3 * t + 2];
    lookup(map.oct, n, c * x + s * y, -s * x + c * y, z, rgb, 0);  // L(R_z(-theta) d)
    plane[0][t] = rgb[0]; plane[1][t] = rgb[1]; plane[2][t] = rgb[2];
  }
  for (let ch = 0; ch < 3; ++ch) { haarForward(plane[ch]); for (let t = 0; t < n * n; ++t) lightHaar[3 * t + ch] = plane[ch][t]; }
}
const color = new Float32Array(nv * 3), g = new Float64Array(3);
const bFirst = M.bounce_pairs > 0 ? buf('bounce_first') : null, bSource = bFirst && buf('bounce_source'), bWeight = bFirst && buf('bounce_weight');
const exitRgb = new Float32Array(bFirst ? nv * 3 : 0);
// The view-independent part (diffuse and bounce) of the light last shaded, so a camera move shades glossy only.
const diffuse = new Float32Array(nv * 3); let diffuseOf = null;
function shadeDiffuse(map, theta) {
  prepareLight(map, theta);
  const L = lightHaar;
  for (let v = 0; v < nv; ++v) {
    let r = 0, gg = 0, b = 0; const o = v * K;
    for (let j = 0; j < K; ++j) { const q = 3 * tIdx[o + j], w = tVal[o + j]; r += w * L[q]; gg += w * L[q + 1]; b += w * L[q + 2]; }
    const sc = tScale[v];
    diffuse[3 * v] = dif[3 * v] * r * sc; diffuse[3 * v + 1] = dif[3 * v + 1] * gg * sc; diffuse[3 * v + 2] = dif[3 * v + 2] * b * sc;
  }
  if (bFirst) {  // one bounce: the diffuse exit radiance of the vertices each one sees, onto its diffuse albedo
    exitRgb.set(diffuse);
    for (let v = 0; v < nv; ++v) {
      let r = 0, gg = 0, b = 0;
      for (let s = bFirst[v]; s < bFirst[v + 1]; ++s) { const u = 3 * bSource[s], w = bWeight[s]; r += w * exitRgb[u]; gg += w * exitRgb[u + 1]; b += w * exitRgb[u + 2]; }
      diffuse[3 * v] += dif[3 * v] * r; diffuse[3 * v + 1] += dif[3 * v + 1] * gg; diffuse[3 * v + 2] += dif[3 * v + 2] * b;
    }
  }
  diffuseOf = {map, theta};
}
// Per-vertex linear radiance towards the eye (viewer_export.h).
function shade(map, theta, eye) {
  if (!diffuseOf || diffuseOf.map !== map || diffuseOf.theta !== theta) shadeDiffuse(map, theta);
  color.set(diffuse);
  if (!lobes.length) return;
  const c = Math.cos(theta), s = Math.sin(theta);
  for (let v = 0; v < nv; ++v) {
    const nx = nrm[3 * v], ny = nrm[3 * v + 1], nz = nrm[3 * v + 2];
    let wx = eye[0] - pos[3 * v], wy = eye[1] - pos[3 * v + 1], wz = eye[2] - pos[3 * v + 2];
    const wl = Math.hypot(wx, wy, wz); wx /= wl; wy /= wl; wz /= wl;
    const co = nx * wx + ny * wy + nz * wz;
    if (!(co > 0)) continue;
    const rx = 2 * co * nx - wx, ry = 2 * co * ny - wy, rz = 2 * co * nz - wz;
    // Visibility at r: bilinear on the gv x gv hemi-octahedral map, clamped at its border.
    const f = 6 * v, lx = frame[f] * rx + frame[f + 1] * ry + frame[f + 2] * rz, ly = frame[f + 3] * rx + frame[f + 4] * ry + frame[f + 5] * rz;
    const l1 = Math.abs(lx) + Math.abs(ly) + Math.max(0, nx * rx + ny * ry + nz * rz), px = lx / l1, py = ly / l1;
    const fa = Math.min(Math.max((px + py + 1) * 0.5 * gv - 0.5, 0), gv - 1), fb = Math.min(Math.max((px - py + 1) * 0.5 * gv - 0.5, 0), gv - 1);
    const a0 = Math.min(Math.floor(fa), gv - 2), b0 = Math.min(Math.floor(fb), gv - 2), da = fa - a0, db = fb - b0, vo = v * gv * gv;
    const vis = ((1 - da) * (1 - db) * gVis[vo + b0 * gv + a0] + da * (1 - db) * gVis[vo + b0 * gv + a0 + 1] +
                 (1 - da) * db * gVis[vo + (b0 + 1) * gv + a0] + da * db * gVis[vo + (b0 + 1) * gv + a0 + 1]) / 255;
    if (!(vis > 0)) continue;
    const tpos = co * (M.albedo_table_size - 1), t0 = Math.min(Math.floor(tpos), M.albedo_table_size - 2), tf = tpos - t0;
    for (let lb = 0; lb < lobes.length; ++lb) {
      const lobe = lobes[lb], k = 3 * v;
      if (lobe.rgb[k] === 0 && lobe.rgb[k + 1] === 0 && lobe.rgb[k + 2] === 0) continue;
      const A = (1 - tf) * lobe.table[t0] + tf * lobe.table[t0 + 1];
      lookup(map.pre[lb], gr, c * rx + s * ry, -s * rx + c * ry, rz, g, 0);
      const w = A * vis;
      color[k] += lobe.rgb[k] * g[0] * w; color[k + 1] += lobe.rgb[k + 1] * g[1] * w; color[k + 2] += lobe.rgb[k + 2] * g[2] * w;
    }
  }
}
// Exposure mapping the tonemap_percentile of vertex luminance to 1 (relight/display.h, over vertices).
function autoExposure() {
  const lum = new Float32Array(nv);
  for (let v = 0; v < nv; ++v) lum[v] = 0.2126 * color[3 * v] + 0.7152 * color[3 * v + 1] + 0.0722 * color[3 * v + 2];
  lum.sort();
  const q = lum[Math.min(nv - 1, Math.max(0, Math.ceil(M.tonemap_percentile / 100 * nv) - 1))];
  return q > 0 ? 1 / q : 1;
}
// WebGL 2 in two passes. A camera change rasterises the mesh once into a visibility buffer: per pixel the
// hit triangle (id + 1, 0 for none) and its perspective-correct barycentrics (two unorm16). Every frame then
// draws one full-screen triangle that interpolates the triangle's three vertex colours (read from a texture
// the shading fills) and applies exposure and the sRGB curve. Turning the light or changing the exposure
// thus costs the shading and one pass over the pixels, not the triangles: a software rasteriser
// (SwiftShader) spends most of a frame on triangle setup for a mesh with about as many triangles as pixels.
const canvas = document.getElementById('canvas');
const W = Math.round(num('w', 640)), H = Math.round(num('h', 480));
canvas.width = W; canvas.height = H; canvas.style.width = W + 'px'; canvas.style.height = H + 'px';
const gl = canvas.getContext('webgl2', {antialias: false, preserveDrawingBuffer: true});
if (!gl) { fail('WebGL 2 is not available'); return; }
const dbg = gl.getExtension('WEBGL_debug_renderer_info');
const renderer = dbg ? gl.getParameter(dbg.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
function compile(type, src) {
  const sh = gl.createShader(type); gl.shaderSource(sh, src); gl.compileShader(sh);
  if (!gl.getShaderParameter(sh, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(sh));
  return sh;
}
function program(vs, fs) {
  const p = gl.createProgram();
  gl.attachShader(p, compile(gl.VERTEX_SHADER, vs)); gl.attachShader(p, compile(gl.FRAGMENT_SHADER, fs));
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
  return p;
}
// Per-vertex and per-triangle data live in 2D textures texW texels wide (texelFetch by index).
const nt = tri.length / 3, texW = Math.min(gl.getParameter(gl.MAX_TEXTURE_SIZE), 2048);
const rowsFor = count => Math.max(1, Math.ceil(count / texW));
if (rowsFor(Math.max(nv, nt)) > gl.getParameter(gl.MAX_TEXTURE_SIZE)) { fail('the model is too large for this GPU\'s textures'); return; }
function dataTexture(internal, format, type, data, count, comps) {
  const rows = rowsFor(count), full = new data.constructor(texW * rows * comps); full.set(data);
  const t = gl.createTexture(); gl.bindTexture(gl.TEXTURE_2D, t);
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST); gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
  gl.texImage2D(gl.TEXTURE_2D, 0, internal, texW, rows, 0, format, type, full);
  return {tex: t, rows, full};
}
// Pass 1: triangle t's corner k is vertex 3t + k of a non-indexed draw; positions are gathered per corner.
const cornerPos = new Float32Array(nt * 9);
for (let i = 0; i < nt * 3; ++i) { const v = tri[i]; cornerPos[3 * i] = pos[3 * v]; cornerPos[3 * i + 1] = pos[3 * v + 1]; cornerPos[3 * i + 2] = pos[3 * v + 2]; }
const visProg = program(`#version 300 es
in vec3 a_pos; uniform mat4 u_clip_from_world; flat out uint v_tri; out vec2 v_bary;
void main() {
  int k = gl_VertexID % 3; v_tri = uint(gl_VertexID / 3) + 1u;
  v_bary = vec2(k == 1 ? 1.0 : 0.0, k == 2 ? 1.0 : 0.0);
  gl_Position = u_clip_from_world * vec4(a_pos, 1.0);
}`, `#version 300 es
precision highp float; precision highp int; flat in uint v_tri; in vec2 v_bary; layout(location = 0) out uvec2 o;
void main() { o = uvec2(v_tri, packUnorm2x16(v_bary)); }`);
const visVao = gl.createVertexArray(); gl.bindVertexArray(visVao);
gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer()); gl.bufferData(gl.ARRAY_BUFFER, cornerPos, gl.STATIC_DRAW);
const aPos = gl.getAttribLocation(visProg, 'a_pos'); gl.enableVertexAttribArray(aPos); gl.vertexAttribPointer(aPos, 3, gl.FLOAT, false, 0, 0);
const visTex = gl.createTexture(); gl.bindTexture(gl.TEXTURE_2D, visTex);
gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST); gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.NEAREST);
gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RG32UI, W, H);
const visFbo = gl.createFramebuffer(); gl.bindFramebuffer(gl.FRAMEBUFFER, visFbo);
gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, visTex, 0);
const depth = gl.createRenderbuffer(); gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, W, H);
gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) !== gl.FRAMEBUFFER_COMPLETE) { fail('the visibility buffer is not renderable'); return; }
gl.bindFramebuffer(gl.FRAMEBUFFER, null);
const uClip = gl.getUniformLocation(visProg, 'u_clip_from_world');
// Pass 2: a full-screen triangle.
const resolveProg = program(`#version 300 es
void main() { gl_Position = vec4(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0, 0.0, 1.0); }`,
`#version 300 es
precision highp float; precision highp int; precision highp usampler2D;
uniform highp usampler2D u_vis, u_tris; uniform highp sampler2D u_rgb; uniform float u_exposure; uniform int u_tex_w;
out vec4 o;
ivec2 at(uint i) { return ivec2(int(i) % u_tex_w, int(i) / u_tex_w); }
float srgb(float x) { x = clamp(x, 0.0, 1.0); return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055; }
void main() {
  uvec2 g = texelFetch(u_vis, ivec2(gl_FragCoord.xy), 0).xy;
  if (g.x == 0u) { o = vec4(0.0, 0.0, 0.0, 1.0); return; }
  uvec3 t = texelFetch(u_tris, at(g.x - 1u), 0).xyz; vec2 b = unpackUnorm2x16(g.y);
  vec3 c = ((1.0 - b.x - b.y) * texelFetch(u_rgb, at(t.x), 0).rgb + b.x * texelFetch(u_rgb, at(t.y), 0).rgb +
            b.y * texelFetch(u_rgb, at(t.z), 0).rgb) * u_exposure;
  o = vec4(srgb(c.r), srgb(c.g), srgb(c.b), 1.0);
}`);
const resolveVao = gl.createVertexArray();
const triTex = dataTexture(gl.RGB32UI, gl.RGB_INTEGER, gl.UNSIGNED_INT, tri, nt, 3);
const rgbTex = dataTexture(gl.RGBA32F, gl.RGBA, gl.FLOAT, new Float32Array(0), nv, 4);  // RGBA: no conversion
gl.useProgram(resolveProg);
gl.uniform1i(gl.getUniformLocation(resolveProg, 'u_vis'), 0); gl.uniform1i(gl.getUniformLocation(resolveProg, 'u_tris'), 1);
gl.uniform1i(gl.getUniformLocation(resolveProg, 'u_rgb'), 2); gl.uniform1i(gl.getUniformLocation(resolveProg, 'u_tex_w'), texW);
const uExp = gl.getUniformLocation(resolveProg, 'u_exposure');
gl.activeTexture(gl.TEXTURE0); gl.bindTexture(gl.TEXTURE_2D, visTex);
gl.activeTexture(gl.TEXTURE1); gl.bindTexture(gl.TEXTURE_2D, triTex.tex);
gl.activeTexture(gl.TEXTURE2); gl.bindTexture(gl.TEXTURE_2D, rgbTex.tex);
gl.viewport(0, 0, W, H);
let visCamera = null;  // the camera the visibility buffer holds
function drawVisibility(cam, key) {
  gl.bindFramebuffer(gl.FRAMEBUFFER, visFbo); gl.useProgram(visProg); gl.bindVertexArray(visVao);
  gl.enable(gl.DEPTH_TEST); gl.clearBufferuiv(gl.COLOR, 0, new Uint32Array(4)); gl.clearBufferfv(gl.DEPTH, 0, [1]);
  gl.uniformMatrix4fv(uClip, false, cam.clip);
  gl.drawArrays(gl.TRIANGLES, 0, nt * 3);
  gl.bindFramebuffer(gl.FRAMEBUFFER, null); gl.disable(gl.DEPTH_TEST);
  visCamera = key;
}
function drawColours(exposure) {
  const f = rgbTex.full;
  for (let v = 0; v < nv; ++v) { f[4 * v] = color[3 * v]; f[4 * v + 1] = color[3 * v + 1]; f[4 * v + 2] = color[3 * v + 2]; }
  gl.activeTexture(gl.TEXTURE2); gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, texW, rgbTex.rows, gl.RGBA, gl.FLOAT, f);
  gl.useProgram(resolveProg); gl.bindVertexArray(resolveVao); gl.uniform1f(uExp, exposure);
  gl.drawArrays(gl.TRIANGLES, 0, 3);
}
// Orbit camera (ViewerOrbitCamera): eye, then clip_from_world = perspective * lookAt (column-major).
function camera(azDeg, elDeg) {
  const az = azDeg * Math.PI / 180, el = Math.min(89, Math.max(-89, elDeg)) * Math.PI / 180;
  const R = M.radius, dist = num('dist', 3) * R, fov = num('fov', 40) * Math.PI / 180, C = M.center;
  const eye = [C[0] + dist * Math.cos(el) * Math.cos(az), C[1] + dist * Math.cos(el) * Math.sin(az), C[2] + dist * Math.sin(el)];
  let f = [C[0] - eye[0], C[1] - eye[1], C[2] - eye[2]]; const fl = Math.hypot(...f); f = f.map(x => x / fl);
  let r = [f[1], -f[0], 0]; const rl = Math.hypot(...r); r = r.map(x => x / rl);  // f x +Z
  const u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]];
  const near = Math.max(1e-4 * dist, dist - 2 * R), far = dist + 2 * R, t = 1 / Math.tan(fov / 2), a = W / H;
  const view = [r[0], u[0], -f[0], 0, r[1], u[1], -f[1], 0, r[2], u[2], -f[2], 0,
                -(r[0] * eye[0] + r[1] * eye[1] + r[2] * eye[2]), -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]),
                f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2], 1];
  const proj = [t / a, 0, 0, 0, 0, t, 0, 0, 0, 0, (far + near) / (near - far), -1, 0, 0, 2 * far * near / (near - far), 0];
  const m = new Float32Array(16);
  for (let c = 0; c < 4; ++c) for (let rr = 0; rr < 4; ++rr) {
    let s = 0; for (let k = 0; k < 4; ++k) s += proj[k * 4 + rr] * view[c * 4 + k]; m[c * 4 + rr] = s;
  }
  return {eye, clip: m};
}
const el = id => document.getElementById(id);
const state = {map: Math.min(M.maps.length - 1, Math.max(0, Math.round(num('map', 0)))), rotate: num('rotate', 0), az: num('az', 30),
               el: num('el', 20), ev: num('ev', 0), exposure: P.has('exposure') ? num('exposure', 1) : null};
M.maps.forEach((m, i) => { const o = document.createElement('option'); o.value = i; o.textContent = m.name; el('map').appendChild(o); });
el('map').value = state.map; el('rotate').value = state.rotate; el('az').value = state.az; el('el').value = state.el; el('ev').value = state.ev;
let autoExp = null;
function frame_(sync) {
  const t0 = performance.now();
  const cam = camera(state.az, state.el);
  shade(maps[state.map], state.rotate * Math.PI / 180, cam.eye);
  if (autoExp === null) autoExp = autoExposure();
  const t1 = performance.now();
  const key = state.az + ',' + state.el;
  if (visCamera !== key) drawVisibility(cam, key);
  drawColours((state.exposure !== null ? state.exposure : autoExp) * Math.pow(2, state.ev));
  if (sync) gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));  // waits for the GPU
  return {total: performance.now() - t0, shade: t1 - t0};
}
function label() { ['rotate', 'az', 'el', 'ev'].forEach(k => el(k + '_v').textContent = state[k]); }
let pending = false;
function request() { if (!pending) { pending = true; requestAnimationFrame(() => { pending = false; const t = frame_(false); label(); statusEl.textContent = `${nv} vertices, top ${K} coefficients, ${t.total.toFixed(1)} ms/frame (shading ${t.shade.toFixed(1)} ms), ${renderer}`; }); } }
el('map').addEventListener('change', () => { state.map = +el('map').value; autoExp = null; request(); });
['rotate', 'az', 'el', 'ev'].forEach(k => el(k).addEventListener('input', () => { state[k] = +el(k).value; request(); }));
// bench=N: N frames with the light turning 360/N degrees per frame, timed twice: pipelined as a browser runs
// them (the GPU draws one frame while JavaScript shades the next; one readPixels after the last waits for all)
// and synced (a readPixels after every frame waits for it: JavaScript and GPU times add up); then N frames
// with the camera orbiting 360/N degrees per frame (pipelined), which rasterise the triangles every frame.
const benchFrames = Math.round(num('bench', 0));
statusEl.dataset.renderer = renderer; statusEl.dataset.vertices = nv;
if (benchFrames > 0) {
  frame_(true);
  const start = state.rotate;
  for (const sync of [false, true]) {
    let shadeMs = 0; const t0 = performance.now();
    for (let i = 0; i < benchFrames; ++i) { state.rotate = start + 360 * (i + 1) / benchFrames; shadeMs += frame_(sync).shade; }
    if (!sync) gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
    const ms = (performance.now() - t0) / benchFrames;
    if (sync) statusEl.dataset.msPerFrameSynced = ms.toFixed(3);
    else { statusEl.dataset.msPerFrame = ms.toFixed(3); statusEl.dataset.shadeMsPerFrame = (shadeMs / benchFrames).toFixed(3); }
  }
  state.rotate = start;
  const az0 = state.az, t0 = performance.now();
  for (let i = 0; i < benchFrames; ++i) { state.az = az0 + 360 * (i + 1) / benchFrames; frame_(false); }
  gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
  statusEl.dataset.msPerFrameOrbit = ((performance.now() - t0) / benchFrames).toFixed(3);
  state.az = az0;
}
const t = frame_(true);
label();
statusEl.dataset.exposure = String(state.exposure !== null ? state.exposure : autoExp);
statusEl.textContent = `${nv} vertices, top ${K} coefficients, ${t.total.toFixed(1)} ms/frame, ${renderer}`;
statusEl.dataset.status = 'ok';
})();
</script>
</body></html>
)HTML";

}  // namespace

void ViewerOptions::Check() const {
  if (top_k < 1) RELIGHT_USER_ERROR() << "viewer top_k = " << top_k << ": keep at least 1 coefficient";
  if (!IsPowerOfTwo(env_resolution) || env_resolution < 2 || env_resolution > 256)
    RELIGHT_USER_ERROR() << "viewer env_resolution = " << env_resolution << ": a power of two in [2, 256]";
  if (top_k > env_resolution * env_resolution)
    RELIGHT_USER_ERROR() << "viewer top_k = " << top_k << " exceeds env_resolution² = " << env_resolution * env_resolution;
  if (!IsPowerOfTwo(glossy_resolution) || glossy_resolution < 2 || glossy_resolution > 256)
    RELIGHT_USER_ERROR() << "viewer glossy_resolution = " << glossy_resolution << ": a power of two in [2, 256]";
  if (glossy_visibility < 2 || glossy_visibility > 16)
    RELIGHT_USER_ERROR() << "viewer glossy_visibility = " << glossy_visibility << ": in [2, 16]";
  if (albedo_table_size < 2) RELIGHT_USER_ERROR() << "viewer albedo_table_size = " << albedo_table_size << ": at least 2";
  if (!(tonemap_percentile > 0 && tonemap_percentile <= 100))
    RELIGHT_USER_ERROR() << "viewer tonemap_percentile = " << tonemap_percentile << ": in (0, 100]";
}

std::string ViewerExport::BriefReport() const {
  std::ostringstream s;
  s << "viewer: " << num_vertices << " vertices, top " << top_k << " Haar coefficients, " << num_maps << " maps, "
    << data_bytes / 1000000.0 << " MB of data, " << seconds << " s -> " << html;
  return s.str();
}

Eigen::Vector3d ViewerCamera::PixelRay(int x, int y) const {
  const Eigen::Vector3d f = (center_world - eye_world).normalized();
  const Eigen::Vector3d r = f.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d u = r.cross(f);
  const double focal_px = 0.5 * height / std::tan(0.5 * fov_y_deg * M_PI / 180);
  return (f + (x + 0.5 - 0.5 * width) / focal_px * r + (0.5 * height - (y + 0.5)) / focal_px * u).normalized();
}

ViewerCamera ViewerOrbitCamera(const Eigen::Vector3d& center_world, double radius, double azimuth_deg,
                               double elevation_deg, double dist_factor, double fov_y_deg, int width, int height) {
  const double az = azimuth_deg * M_PI / 180, el = std::clamp(elevation_deg, -89.0, 89.0) * M_PI / 180;
  ViewerCamera c;
  c.center_world = center_world;
  c.eye_world = center_world + dist_factor * radius *
                                   Eigen::Vector3d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  c.fov_y_deg = fov_y_deg;
  c.width = width;
  c.height = height;
  return c;
}

ViewerExport WriteViewerAssets(const std::string& dir, const RecoveredModel& model, const VisibilityData& visibility,
                               const TransportRenderer& transport,
                               const std::vector<std::pair<std::string, EnvMap>>& maps, const ViewerOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  options.Check();
  const TriangleMesh& mesh = model.mesh;
  const size_t nv = mesh.num_vertices();
  RELIGHT_CHECK_EQ(mesh.normals.size(), nv);
  RELIGHT_CHECK_EQ(visibility.per_vertex.size(), nv);
  RELIGHT_CHECK(!maps.empty()) << "the viewer needs at least one map";
  const int n = options.env_resolution, k = options.top_k;
  const ReflectanceModel& refl = model.reflectance;
  const int num_lobes = static_cast<int>(refl.basis.size());
  const auto weights = VertexMaterialWeights(mesh, static_cast<int>(refl.materials.size()), "viewer export");

  // Per-vertex RGB coefficient of each lobe: Σ_m w_m coefficients[m][b].
  std::vector<Eigen::Vector3f> lobe_rgb(size_t(num_lobes) * nv, Eigen::Vector3f::Zero());
  for (size_t v = 0; v < nv; ++v)
    for (size_t m = 0; m < refl.materials.size(); ++m)
      for (int b = 0; b < num_lobes; ++b)
        lobe_rgb[size_t(b) * nv + v] += (weights[v][m] * refl.materials[m].coefficients[b]).cast<float>();

  Buffers buffers;
  OrderedJson meta;
  meta["num_vertices"] = nv;
  meta["num_faces"] = mesh.num_faces();
  meta["top_k"] = k;
  meta["env_resolution"] = n;
  meta["glossy_resolution"] = options.glossy_resolution;
  meta["glossy_visibility"] = options.glossy_visibility;
  meta["albedo_table_size"] = options.albedo_table_size;
  meta["tonemap_percentile"] = options.tonemap_percentile;
  meta["center"] = {model.center.x(), model.center.y(), model.center.z()};
  meta["radius"] = model.radius;
  {
    std::vector<float> p(nv * 3), nn(nv * 3);
    for (size_t v = 0; v < nv; ++v)
      for (int c = 0; c < 3; ++c) {
        p[3 * v + c] = mesh.vertices[v][c];
        nn[3 * v + c] = mesh.normals[v][c];
      }
    std::vector<uint32_t> idx(mesh.num_faces() * 3);
    for (size_t f = 0; f < mesh.num_faces(); ++f)
      for (int c = 0; c < 3; ++c) idx[3 * f + c] = static_cast<uint32_t>(mesh.faces[f][c]);
    buffers.Add("positions", "f32", p);
    buffers.Add("normals", "f32", nn);
    buffers.Add("indices", "u32", idx);
  }

  // Diffuse: the transport renderer's Lambertian rows, top k, int16 with a per-vertex scale.
  {
    RELIGHT_CHECK_EQ(transport.env_resolution(), n);
    const float kInvPi = static_cast<float>(1.0 / M_PI);
    std::vector<std::pair<float, uint16_t>> ranked;  // (-|value|, position in the row): ascending = largest first
    std::vector<uint16_t> index(nv * k, 0);
    std::vector<int16_t> value(nv * k, 0);
    std::vector<float> scale(nv, 0.0f), diffuse(nv * 3, 0.0f);
    for (size_t v = 0; v < nv; ++v) {
      const TransportRenderer::Row row = transport.ObjectRow(static_cast<uint32_t>(v));
      ranked.clear();
      float largest = 0;  // of the row with the 1/π the page's term has
      for (uint32_t q = 0; q < row.size; ++q) {
        ranked.emplace_back(-std::abs(row.value[q]), static_cast<uint16_t>(q));
        largest = std::max(largest, std::abs(row.value[q]) * kInvPi);
      }
      const size_t kept = std::min(ranked.size(), size_t(k));
      std::nth_element(ranked.begin(), ranked.begin() + kept, ranked.end());
      std::sort(ranked.begin(), ranked.begin() + kept,
                [](const auto& a, const auto& b) { return a.second < b.second; });  // ascending indices
      scale[v] = largest / 32767.0f;
      for (size_t q = 0; q < kept; ++q) {
        index[v * k + q] = row.index[ranked[q].second];
        value[v * k + q] = static_cast<int16_t>(std::lround(row.value[ranked[q].second] * kInvPi / scale[v]));
      }
      for (int b = 0; b < num_lobes; ++b)
        if (refl.basis[b].model == BrdfModel::kLambertian)
          for (int c = 0; c < 3; ++c) diffuse[3 * v + c] += lobe_rgb[size_t(b) * nv + v][c];
    }
    buffers.Add("diffuse_rgb", "f32", diffuse);
    buffers.Add("transport_index", "u16", index);
    buffers.Add("transport_value", "i16", value);
    buffers.Add("transport_scale", "f32", scale);
  }

  // The one bounce the model was solved with (RecoveredModel::bounce_rays_per_side): each vertex's sources and
  // their weights (visibility/bounce.h), the occluders blocking; the page gathers the diffuse exit radiance.
  meta["bounce_pairs"] = 0;
  if (model.bounce_rays_per_side > 0) {
    RELIGHT_CHECK(transport.interreflection()) << "the viewer's transport renderer lacks the model's bounce";
    const BounceSamples& bounce = transport.object_bounce();
    meta["bounce_pairs"] = bounce.hit_vertex.size();
    buffers.Add("bounce_first", "u32", bounce.first);
    buffers.Add("bounce_source", "u32", bounce.hit_vertex);
    buffers.Add("bounce_weight", "f32", bounce.weight);
  }

  // Glossy lobes: per-vertex RGB, directional albedo tables, coarse visibility.
  std::vector<int> glossy;
  for (int b = 0; b < num_lobes; ++b)
    if (refl.basis[b].model != BrdfModel::kLambertian) glossy.push_back(b);
  meta["glossy_lobes"] = OrderedJson::array();
  for (size_t g = 0; g < glossy.size(); ++g) {
    const BrdfLobe& lobe = refl.basis[glossy[g]];
    std::vector<float> rgb(nv * 3);
    for (size_t v = 0; v < nv; ++v)
      for (int c = 0; c < 3; ++c) rgb[3 * v + c] = lobe_rgb[size_t(glossy[g]) * nv + v][c];
    buffers.Add("glossy_rgb_" + std::to_string(g), "f32", rgb);
    meta["glossy_lobes"].push_back({{"lobe", lobe.Describe()},
                                    {"kernel_exponent", KernelExponent(lobe)},
                                    {"albedo_table", DirectionalAlbedoTable(lobe, options.albedo_table_size)}});
  }
  if (!glossy.empty()) {
    const int N = visibility.resolution, gv = options.glossy_visibility;
    RELIGHT_CHECK(N % gv == 0) << "visibility resolution " << N << " is not a multiple of glossy_visibility " << gv;
    const std::vector<double> sr = HemiOctTexelSolidAngles(N);
    std::vector<uint8_t> coarse(nv * gv * gv);
    tbb::parallel_for(size_t(0), nv, [&](size_t v) {
      const std::vector<float> dense = visibility.DenseMap(v);
      const int block = N / gv;
      for (int cb = 0; cb < gv; ++cb)
        for (int ca = 0; ca < gv; ++ca) {
          double sum = 0, weight = 0;
          for (int j = cb * block; j < (cb + 1) * block; ++j)
            for (int i = ca * block; i < (ca + 1) * block; ++i) {
              sum += sr[size_t(j) * N + i] * dense[size_t(j) * N + i];
              weight += sr[size_t(j) * N + i];
            }
          coarse[v * gv * gv + cb * gv + ca] =
              static_cast<uint8_t>(std::lround(255 * std::clamp(sum / weight, 0.0, 1.0)));
        }
    });
    buffers.Add("glossy_visibility", "u8", coarse);
  }

  // Maps: env_resolution² texel values and one prefiltered map per glossy lobe.
  std::vector<PrefilterKernel> kernels;
  for (size_t g = 0; g < glossy.size(); ++g)
    kernels.emplace_back(KernelExponent(refl.basis[glossy[g]]), options.glossy_resolution, n);
  meta["maps"] = OrderedJson::array();
  for (size_t i = 0; i < maps.size(); ++i) {
    const Image oct = ViewerOctahedral(maps[i].second, n);
    RELIGHT_CHECK_EQ(oct.channels, 3);
    const std::string name = "map_" + std::to_string(i);
    buffers.Add(name, "f32", oct.pixels);
    OrderedJson entry = {{"name", maps[i].first}, {"oct", name}, {"prefiltered", OrderedJson::array()}};
    for (size_t g = 0; g < glossy.size(); ++g) {
      const std::string pre = name + "_lobe_" + std::to_string(g);
      buffers.Add(pre, "f32", kernels[g].Apply(oct));
      entry["prefiltered"].push_back(pre);
    }
    meta["maps"].push_back(entry);
  }

  std::filesystem::create_directories(dir);
  ViewerExport out;
  out.html = std::filesystem::absolute(std::filesystem::path(dir) / "viewer.html").string();
  out.data = std::filesystem::absolute(std::filesystem::path(dir) / "viewer_data.js").string();
  const OrderedJson header = {{"format", "relight-viewer"}, {"version", 1}, {"meta", meta}, {"index", buffers.index}};
  std::string js = header.dump();
  js.pop_back();  // the closing brace: the buffers follow
  js = "window.RELIGHT_VIEWER_DATA = " + js + ",\n\"buffers\": {" + buffers.js + "}};\n";
  WriteFileAtomic(out.data, js);
  WriteFileAtomic(out.html, kViewerHtml);
  out.num_vertices = nv;
  out.top_k = k;
  out.num_maps = static_cast<int>(maps.size());
  out.data_bytes = js.size();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace relight
