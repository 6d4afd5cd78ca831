// Engine-free. The splat module of the three.js plugin, the Babylon.js extension and
// samples/web: the per-Gaussian part of the 3DGS EWA splatting of
// libhaha/render/gaussian_kernels.h (project_gaussian, plain / not antialiased, as the avatar
// render uses it), in float64, and the depth sort of gaussian_raster.cpp (by camera z of the
// centre, ties by index): SplatProjector. The GLSL of the quads, of the varyings they pass and
// of the per-pixel part (alpha = min(0.99, o exp(power)), skipped below 1/255):
// SPLAT_GLSL_VERTEX, splatVaryings, SPLAT_GLSL_FRAGMENT. The engines' splat layer in an
// engine's GLSL dialect (splatLayerShaders) with its splat texture (SplatTexture) and camera
// (openCvFromGl). The depth test against the mesh and the compositing are the engine's
// (blending) or the renderer's (samples/web/lib/renderer.js).
//
// Camera: OpenCV pinhole, { width, height, fx, fy, cx, cy, R (row-major 3 x 3,
// world -> camera), t (3), near, far }, pixel centres at +0.5.

export const DILATION = 0.3;        // low-pass filter added to cov2d (px^2)
export const ALPHA_MIN = 1 / 255;
export const ALPHA_MAX = 0.99;
export const FOV_CLAMP = 1.3;
export const MIN_QUAT_NORM2 = 1e-24;

// Vertex layout written by project(): 16 floats per visible Gaussian, depth-sorted, written
// four times (one per corner of its quad; the shader picks the corner from gl_VertexID % 4):
// instanced drawing would be the natural choice, but SwiftShader (headless Chromium without
// a GPU) pays a whole draw call per instance, 30x slower for 9k Gaussians.
//   0..3  pixel box x0, y0, x1 + 1, y1 + 1 (inclusive box of the C++ rasterizer)
//   4..5  centre mx, my (pixels)         6..8  conic ca, cb, cc
//   9     opacity  10 power_min  11 camera z     12..14 colour
//   15    normalized device depth of the centre (cam.depthA, cam.depthB: a GL projection's
//         P[10], P[14]; ndc = (-A z + B) / z for camera z minus cam.depthMargin; 0 without)
export const STRIDE = 16;
export const CORNERS = 4;

export class SplatProjector {
  constructor(capacity) {
    this.resize(capacity);
  }

  resize(n) {
    this.capacity = n;
    this.tmp = new Float64Array(STRIDE * n);
    this.out = new Float32Array(CORNERS * STRIDE * n);
    this.keys = new Uint32Array(2 * n);
    this.keyView = new Float32Array(this.keys.buffer, 0, n);
    this.order = new Uint32Array(2 * n);
  }

  // means (N,3), quats (N,4 wxyz), scales (N,3), opacity (N), color (N,3) -> this.out,
  // returns the number of visible Gaussians (instances).
  // options.corners = 0: only project and sort (then write() copies them out).
  project(cam, N, means, quats, scales, opacity, color, options = {}) {
    if (N > this.capacity) this.resize(N);
    const R = cam.R, t = cam.t, { fx, fy, cx, cy, depthA, depthB } = cam;
    const depthMargin = cam.depthMargin || 0;
    const ulo = -FOV_CLAMP * cx / fx, uhi = FOV_CLAMP * (cam.width - cx) / fx;
    const vlo = -FOV_CLAMP * cy / fy, vhi = FOV_CLAMP * (cam.height - cy) / fy;
    const tmp = this.tmp;
    let n = 0;
    const vis = this.order;
    for (let i = 0; i < N; i++) {
      const X = means[3 * i], Y = means[3 * i + 1], Z = means[3 * i + 2];
      const px = R[0] * X + R[1] * Y + R[2] * Z + t[0];
      const py = R[3] * X + R[4] * Y + R[5] * Z + t[1];
      const z = R[6] * X + R[7] * Y + R[8] * Z + t[2];
      if (!(z > cam.near)) continue;
      let qw = quats[4 * i], qx = quats[4 * i + 1], qy = quats[4 * i + 2], qz = quats[4 * i + 3];
      const qn2 = qw * qw + qx * qx + qy * qy + qz * qz;
      if (!(qn2 > MIN_QUAT_NORM2)) continue;
      const qn = Math.sqrt(qn2);
      qw /= qn; qx /= qn; qy /= qn; qz /= qn;
      // M = R(q) diag(s); Sigma = M M^T
      const sx = scales[3 * i], sy = scales[3 * i + 1], sz = scales[3 * i + 2];
      const r00 = 1 - 2 * (qy * qy + qz * qz), r01 = 2 * (qx * qy - qw * qz), r02 = 2 * (qx * qz + qw * qy);
      const r10 = 2 * (qx * qy + qw * qz), r11 = 1 - 2 * (qx * qx + qz * qz), r12 = 2 * (qy * qz - qw * qx);
      const r20 = 2 * (qx * qz - qw * qy), r21 = 2 * (qy * qz + qw * qx), r22 = 1 - 2 * (qx * qx + qy * qy);
      const m00 = r00 * sx, m01 = r01 * sy, m02 = r02 * sz;
      const m10 = r10 * sx, m11 = r11 * sy, m12 = r12 * sz;
      const m20 = r20 * sx, m21 = r21 * sy, m22 = r22 * sz;
      const s00 = m00 * m00 + m01 * m01 + m02 * m02, s01 = m00 * m10 + m01 * m11 + m02 * m12;
      const s02 = m00 * m20 + m01 * m21 + m02 * m22, s11 = m10 * m10 + m11 * m11 + m12 * m12;
      const s12 = m10 * m20 + m11 * m21 + m12 * m22, s22 = m20 * m20 + m21 * m21 + m22 * m22;
      // Jacobian with the tan-space clamp
      const uRaw = px / z, vRaw = py / z;
      const u = uRaw < ulo ? ulo : uRaw > uhi ? uhi : uRaw;
      const v = vRaw < vlo ? vlo : vRaw > vhi ? vhi : vRaw;
      const j00 = fx / z, j02 = -fx * u / z, j11 = fy / z, j12 = -fy * v / z;
      // t0 = j00 w0 + j02 w2, t1 = j11 w1 + j12 w2 (w_k = rows of the camera rotation)
      const t0x = j00 * R[0] + j02 * R[6], t0y = j00 * R[1] + j02 * R[7], t0z = j00 * R[2] + j02 * R[8];
      const t1x = j11 * R[3] + j12 * R[6], t1y = j11 * R[4] + j12 * R[7], t1z = j11 * R[5] + j12 * R[8];
      const st0x = s00 * t0x + s01 * t0y + s02 * t0z, st0y = s01 * t0x + s11 * t0y + s12 * t0z, st0z = s02 * t0x + s12 * t0y + s22 * t0z;
      const st1x = s00 * t1x + s01 * t1y + s02 * t1z, st1y = s01 * t1x + s11 * t1y + s12 * t1z, st1z = s02 * t1x + s12 * t1y + s22 * t1z;
      const a = t0x * st0x + t0y * st0y + t0z * st0z + DILATION;
      const b = t0x * st1x + t0y * st1y + t0z * st1z;
      const c = t1x * st1x + t1y * st1y + t1z * st1z + DILATION;
      const det = a * c - b * b;
      if (!(det > 0) || !(a < 1e30) || !(c < 1e30)) continue;
      const o = opacity[i];
      if (!(o >= ALPHA_MIN)) continue;
      const mx = fx * uRaw + cx, my = fy * vRaw + cy;
      const k = 2 * Math.log(o / ALPHA_MIN) * 1.001 + 1e-3;
      const hx = Math.sqrt(k * a), hy = Math.sqrt(k * c);
      let x0 = Math.ceil(mx - hx - 0.5), x1 = Math.floor(mx + hx - 0.5);
      let y0 = Math.ceil(my - hy - 0.5), y1 = Math.floor(my + hy - 0.5);
      if (!(x0 <= x1) || !(y0 <= y1)) continue;
      x0 = Math.max(x0, 0); y0 = Math.max(y0, 0);
      x1 = Math.min(x1, cam.width - 1); y1 = Math.min(y1, cam.height - 1);
      if (x0 > x1 || y0 > y1) continue;
      const p = STRIDE * i;
      tmp[p] = x0; tmp[p + 1] = y0; tmp[p + 2] = x1 + 1; tmp[p + 3] = y1 + 1;
      tmp[p + 4] = mx; tmp[p + 5] = my;
      tmp[p + 6] = c / det; tmp[p + 7] = -b / det; tmp[p + 8] = a / det;
      tmp[p + 9] = o; tmp[p + 10] = -0.5 * k; tmp[p + 11] = z;
      tmp[p + 12] = color[3 * i]; tmp[p + 13] = color[3 * i + 1]; tmp[p + 14] = color[3 * i + 2];
      const zd = z - depthMargin;
      tmp[p + 15] = depthA === undefined ? 0 : (-depthA * zd + depthB) / zd;
      this.keyView[n] = z;  // float32, as the C++ rasterizer sorts
      vis[n++] = i;
    }
    const sorted = this._sort(n);
    this.sorted = sorted;
    if (options.corners === 0) return n;  // the caller reads this.tmp in this.sorted order (write())
    const out = this.out;
    for (let s = 0; s < n; s++) {
      const src = STRIDE * sorted[s], dst = CORNERS * STRIDE * s;
      for (let k = 0; k < STRIDE; k++) {
        const v = tmp[src + k];
        out[dst + k] = v; out[dst + STRIDE + k] = v; out[dst + 2 * STRIDE + k] = v; out[dst + 3 * STRIDE + k] = v;
      }
    }
    return n;
  }

  // The n projected Gaussians of the last project() into out (STRIDE floats each), in depth
  // order, front to back or (backToFront) back to front for "over" blending.
  write(out, n, backToFront = false) {
    const tmp = this.tmp, sorted = this.sorted;
    for (let s = 0; s < n; s++) {
      const src = STRIDE * sorted[backToFront ? n - 1 - s : s], dst = STRIDE * s;
      for (let k = 0; k < STRIDE; k++) out[dst + k] = tmp[src + k];
    }
  }

  // Visible Gaussians (this.order[0..n), in index order) sorted by (float32 z, index):
  // stable LSD radix sort on the bits of z (positive floats order like their bit patterns),
  // as gaussian_raster.cpp sort_by_depth does.
  _sort(n) {
    let keys = this.keys.subarray(0, n), keys2 = this.keys.subarray(this.capacity, this.capacity + n);
    let idx = this.order.subarray(0, n), idx2 = this.order.subarray(this.capacity, this.capacity + n);
    const hist = new Uint32Array(257);
    for (let shift = 0; shift < 32; shift += 8) {
      hist.fill(0);
      for (let k = 0; k < n; k++) hist[((keys[k] >>> shift) & 255) + 1]++;
      for (let b = 0; b < 256; b++) hist[b + 1] += hist[b];
      for (let k = 0; k < n; k++) {
        const dst = hist[(keys[k] >>> shift) & 255]++;
        keys2[dst] = keys[k];
        idx2[dst] = idx[k];
      }
      [keys, keys2] = [keys2, keys];
      [idx, idx2] = [idx2, idx];
    }
    return idx;  // four passes: back in the first halves
  }
}

// --- GLSL (ES 3.00, in any engine's dialect) ---

// The flat varyings a splat's fragments read, declared with qualifier q ('out' / 'in', or
// Babylon's 'varying'): centre (pixels), conic, opacity and power_min, colour.
export function splatVaryings(q) {
  return `flat ${q} vec2 vMean;
flat ${q} vec3 vConic;
flat ${q} vec2 vParams;
flat ${q} vec3 vColor;`;
}

// Vertex shader functions (after splatVaryings): the vertex of corner `corner`
// (gl_VertexID % CORNERS: bit 0 = right, bit 1 = bottom) of a splat's pixel box (x0, y0,
// x1 + 1, y1 + 1); a pixel (rows top-down) as clip x, y of a viewport of `size` pixels; the
// varyings from a splat's vec4s 1 to 3 (mean and conic.ab | conic.c, opacity, power_min, z |
// colour).
export const SPLAT_GLSL_VERTEX = /* glsl */ `
vec2 hahaSplatCorner(vec4 box, int corner) {
  return mix(box.xy, box.zw, vec2(float(corner & 1), float(corner >> 1)));
}
vec2 hahaPixelToClip(vec2 pix, vec2 size) {
  return vec2(2.0 * pix.x / size.x - 1.0, 1.0 - 2.0 * pix.y / size.y);
}
void hahaSplatVaryings(vec4 meanConic, vec4 params, vec4 color) {
  vMean = meanConic.xy;
  vConic = vec3(meanConic.zw, params.x);
  vParams = params.yz;
  vColor = color.rgb;
}`;

// Fragment shader function (after splatVaryings): libhaha/render/gaussian_kernels.h
// pixel_alpha, the splat's alpha at `pixel` (the fragment's centre, pixels, rows top-down);
// discards the fragment below the cut-offs.
export const SPLAT_GLSL_FRAGMENT = /* glsl */ `
float hahaSplatAlpha(vec2 pixel) {
  vec2 d = pixel - vMean;
  float power = -0.5 * (vConic.x * d.x * d.x + vConic.z * d.y * d.y) - vConic.y * d.x * d.y;
  if (power < vParams.y) discard;
  float alpha = min(0.99, vParams.x * exp(power));
  if (alpha < 1.0 / 255.0) discard;
  return alpha;
}`;

// Index buffer of n quads, two triangles each over its CORNERS vertices (at least one quad:
// n = 0 gives one degenerate quad, so that an engine has a buffer to bind).
export function quadIndices(n) {
  const index = new Uint32Array(6 * Math.max(1, n));
  for (let i = 0; i < n; i++) index.set([4 * i, 4 * i + 1, 4 * i + 2, 4 * i + 2, 4 * i + 1, 4 * i + 3], 6 * i);
  return index;
}

// --- the engines' splat layer: a float texture of splats, quads drawn back to front ---

export const SPLATS_PER_ROW = 512;  // splats per texture row: STRIDE floats = 4 RGBA32F texels each

// The avatar's Gaussians projected for one camera into this.data (a SPLATS_PER_ROW * 4 wide,
// RGBA float texture), back to front for premultiplied "over" blending (same sum as the
// rasterizer's front-to-back compositing). The engine uploads this.data as a texture named
// `splats` and draws 6 * n indices of this.indices (quadIndices) with splatLayerShaders.
export class SplatTexture {
  constructor(N) {
    this.projector = new SplatProjector(N);
    this.width = 4 * SPLATS_PER_ROW;
    this.height = Math.max(1, Math.ceil(N / SPLATS_PER_ROW));
    this.data = new Float32Array(4 * this.width * this.height);
    this.indices = quadIndices(N);
  }

  // Projects the posed Gaussians of an Avatar (avatar.js: means, quats, scales, gOpacity,
  // gColor) for cam into this.data; returns how many are drawn.
  project(cam, a) {
    const n = this.projector.project(cam, a.N, a.means, a.quats, a.scales, a.gOpacity, a.gColor, { corners: 0 });
    this.projector.write(this.data, n, true);
    return n;
  }
}

// The layer's shaders in an engine's GLSL dialect. The vertex shader reads splat
// gl_VertexID / 4 from the `splats` texture (SplatTexture) and places its corner
// gl_VertexID % 4 in the viewport hahaViewport (x, y, width, height, pixels) at the centre's
// depth; the fragment shader computes the alpha there and writes the premultiplied colour.
// dialect: { vertexOut, fragmentIn (the varying qualifiers), vertexHead (declarations),
// clipW (the w of gl_Position: 1.0), fragmentHead, writeColor (GLSL statements from vColor
// and alpha) }.
export function splatLayerShaders(dialect) {
  const { vertexOut, fragmentIn, vertexHead = '', clipW = '1.0', fragmentHead = '', writeColor } = dialect;
  const vertex = /* glsl */ `
precision highp float;
precision highp int;
precision highp sampler2D;
${vertexHead}
uniform sampler2D splats;  // 4 texels per splat: rect | mean, conic.ab | conic.c, opacity, power_min, z | colour, ndc z
uniform vec4 hahaViewport; // x, y, width, height (pixels)
${splatVaryings(vertexOut)}
${SPLAT_GLSL_VERTEX}
void main() {
  int s = gl_VertexID / 4, corner = gl_VertexID % 4;
  ivec2 b = ivec2((s % ${SPLATS_PER_ROW}) * 4, s / ${SPLATS_PER_ROW});
  vec4 t0 = texelFetch(splats, b, 0), t1 = texelFetch(splats, b + ivec2(1, 0), 0);
  vec4 t2 = texelFetch(splats, b + ivec2(2, 0), 0), t3 = texelFetch(splats, b + ivec2(3, 0), 0);
  vec2 pix = hahaSplatCorner(t0, corner);
  gl_Position = vec4(hahaPixelToClip(pix, hahaViewport.zw), t3.w, ${clipW});
  hahaSplatVaryings(t1, t2, t3);
}`;
  const fragment = /* glsl */ `
precision highp float;
uniform vec4 hahaViewport;
${splatVaryings(fragmentIn)}
${fragmentHead}
${SPLAT_GLSL_FRAGMENT}
void main() {
  float alpha = hahaSplatAlpha(vec2(gl_FragCoord.x - hahaViewport.x, hahaViewport.w - (gl_FragCoord.y - hahaViewport.y)));
  ${writeColor}
}`;
  return { vertex, fragment };
}

// The OpenCV camera of project() for a GL perspective projection P and a model-view matrix E
// (column-major 4 x 4, E: the layer's frame -> view space) over a W x H viewport. s = 1: the
// view space is right-handed (the camera looks along -z, P[11] = -1); s = -1: left-handed
// (along +z, P[11] = 1). The depth of the centres is written as P writes it (depthA, depthB).
export function openCvFromGl(P, E, W, H, near, s = 1) {
  return {
    width: W, height: H,
    fx: P[0] * W / 2, fy: P[5] * H / 2, cx: (1 - s * P[8]) * W / 2, cy: (1 + s * P[9]) * H / 2,
    R: [E[0], E[4], E[8], -E[1], -E[5], -E[9], -s * E[2], -s * E[6], -s * E[10]],
    t: [E[12], -E[13], -s * E[14]],
    near, far: Infinity, depthA: s * P[10], depthB: P[14],
  };
}
