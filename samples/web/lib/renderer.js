// The merged avatar render of libhaha/render/avatar_render.h in WebGL2 (three.js):
//
//   1. mesh pass   -> float target: rgb = M (texture, bilinear through texelFetch exactly
//                     as render/texture.h samples), a = camera z of the surface (0 = none);
//                     no face culling, nearest surface wins. The exact pass (EXACT_VS/FS)
//                     redoes render/mesh_raster.h per pixel; the glTF-skin display mode uses a
//                     plain three.js material (GPU skinning, GPU coverage and interpolation)
//   2. splat pass  -> float target, front to back ("under" blending: dst += (1 - A_dst) src,
//                     src premultiplied): C_front and A = 1 - prod(1 - alpha_i). Quads (one per
//                     Gaussian, its pixel box) are drawn in the order of the Gaussians sorted by the camera z of their centre (splat.js); a
//                     fragment is dropped where the centre z > D + margin (D read from pass 1
//                     at that pixel): the rasterizer's depth test, which ends the pixel there
//                     because every later Gaussian is deeper
//   3. composite   -> 8-bit target: I = C_front + (1 - A) (m M + (1 - m) B), rounded to 8 bits
//                     as haha render's PNGs; then copied to the canvas (reading the canvas
//                     back stalls Chromium for hundreds of ms, the 8-bit target does not)
import * as THREE from 'three';
import { STRIDE, CORNERS, splatVaryings, SPLAT_GLSL_VERTEX, SPLAT_GLSL_FRAGMENT, quadIndices } from '../../../format/js/splat.js';

const MESH_VS = /* glsl */ `
#include <common>
#include <skinning_pars_vertex>
varying vec2 vUv;
varying float vZ;
varying float vCoverage;
void main() {
  vUv = uv;
#ifdef USE_COLOR_ALPHA
  vCoverage = color.a;  // the mesh coverage (COLOR_0 alpha)
#else
  vCoverage = 1.0;
#endif
  #include <skinbase_vertex>
  #include <begin_vertex>
  #include <skinning_vertex>
  vec4 mv = modelViewMatrix * vec4(transformed, 1.0);
  vZ = -mv.z;  // OpenCV camera z
  gl_Position = projectionMatrix * mv;
}`;

// Bilinear, clamp to edge, texel centres at (i + 0.5) / W (render/texture.h bilinear_tap).
const MESH_FS = /* glsl */ `
uniform highp sampler2D map;
varying vec2 vUv;
varying float vZ;
varying float vCoverage;
void main() {
  if (vCoverage < 0.5) discard;  // the coverage cut (render/mesh_raster.h), glTF's MASK
  ivec2 size = textureSize(map, 0);
  float xmax = float(size.x - 1), ymax = float(size.y - 1);
  float x = clamp(vUv.x * float(size.x) - 0.5, 0.0, xmax);
  float y = clamp(vUv.y * float(size.y) - 0.5, 0.0, ymax);
  int x0 = min(int(x), size.x - 1), y0 = min(int(y), size.y - 1);
  int x1 = min(x0 + 1, size.x - 1), y1 = min(y0 + 1, size.y - 1);
  float fx = x - float(x0), fy = y - float(y0);
  vec3 c00 = texelFetch(map, ivec2(x0, y0), 0).rgb, c01 = texelFetch(map, ivec2(x1, y0), 0).rgb;
  vec3 c10 = texelFetch(map, ivec2(x0, y1), 0).rgb, c11 = texelFetch(map, ivec2(x1, y1), 0).rgb;
  vec3 c = (1.0 - fx) * (1.0 - fy) * c00 + fx * (1.0 - fy) * c01 + (1.0 - fx) * fy * c10 + fx * fy * c11;
  gl_FragColor = vec4(c, vZ);
}`;

// The exact mesh pass (render/mesh_raster.h in a shader). One vertex per triangle corner,
// no vertex attributes: gl_VertexID / 3 is the face, whose corners' posed positions and UVs
// are read from textures. Every corner outputs the whole triangle (camera space) as flat
// varyings, so the fragment shader can redo the C++ rasterizer's per-pixel maths: the ray
// through the pixel centre, edge functions with canonical edge normals and the top-left
// rule, perspective-correct barycentrics, z = det / dot(d, N), the near/far test; z goes to
// gl_FragDepth (linear, 32-bit float depth buffer: the nearest surface wins, ties to the
// lower face index as in C++). The GPU only has to produce a fragment for every pixel centre
// inside the triangle: each corner is pushed outward so that every edge moves DILATE pixels
// out (more than any GPU's sub-pixel snapping), and the exact test drops the extra pixels.
const EXACT_VS = /* glsl */ `
precision highp float;
precision highp int;
precision highp sampler2D;
precision highp isampler2D;
uniform sampler2D posTex;   // posed glTF vertices (xyz)
uniform sampler2D uvTex;    // glTF UVs (xy), mesh coverage (z)
uniform isampler2D faceTex; // faces (xyz = glTF vertex indices)
uniform mat3 camR;          // OpenCV world -> camera
uniform vec3 camT;
uniform vec4 K;             // fx, fy, cx, cy
uniform vec2 viewport;      // W, H
uniform vec2 nearFar;
flat out vec3 c0;
flat out vec3 c1;
flat out vec3 c2;
flat out vec3 t0;
flat out vec3 t1;
flat out vec3 t2;
const float DILATE = 0.125;  // pixels
ivec2 at(int i, int w) { return ivec2(i % w, i / w); }
vec2 pixel(vec3 c) { return vec2(K.x * c.x / c.z + K.z, K.y * c.y / c.z + K.w); }
void main() {
  int f = gl_VertexID / 3, corner = gl_VertexID % 3;
  int fw = textureSize(faceTex, 0).x, vw = textureSize(posTex, 0).x;
  ivec3 idx = texelFetch(faceTex, at(f, fw), 0).xyz;
  c0 = camR * texelFetch(posTex, at(idx.x, vw), 0).xyz + camT;
  c1 = camR * texelFetch(posTex, at(idx.y, vw), 0).xyz + camT;
  c2 = camR * texelFetch(posTex, at(idx.z, vw), 0).xyz + camT;
  t0 = texelFetch(uvTex, at(idx.x, vw), 0).xyz;
  t1 = texelFetch(uvTex, at(idx.y, vw), 0).xyz;
  t2 = texelFetch(uvTex, at(idx.z, vw), 0).xyz;
  vec3 cur = corner == 0 ? c0 : (corner == 1 ? c1 : c2);
  if (min(c0.z, min(c1.z, c2.z)) > nearFar.x) {
    vec2 q0 = pixel(c0), q1 = pixel(c1), q2 = pixel(c2);
    vec2 qp = corner == 0 ? q2 : (corner == 1 ? q0 : q1);
    vec2 qc = corner == 0 ? q0 : (corner == 1 ? q1 : q2);
    vec2 qn = corner == 0 ? q1 : (corner == 1 ? q2 : q0);
    vec2 e1 = q1 - q0, e2 = q2 - q0;
    float s = e1.x * e2.y - e1.y * e2.x >= 0.0 ? 1.0 : -1.0;
    vec2 pos = qc;
    vec2 a = qc - qp, b = qn - qc;
    if (dot(a, a) > 0.0 && dot(b, b) > 0.0) {
      a = normalize(a);
      b = normalize(b);
      vec2 n1 = -s * vec2(-a.y, a.x), n2 = -s * vec2(-b.y, b.x);  // outward edge normals
      float det = n1.x * n2.y - n1.y * n2.x;
      vec2 off = abs(det) > 1e-3 ? vec2(n2.y - n1.y, n1.x - n2.x) / det : n1 + n2;
      float len = length(off);
      if (len > 32.0) off *= 32.0 / len;
      pos += DILATE * off;
    }
    gl_Position = vec4(2.0 * pos.x / viewport.x - 1.0, 1.0 - 2.0 * pos.y / viewport.y, 0.0, 1.0);
  } else {
    // Crosses the near plane: no dilation, GL clips (the fragment test is still exact).
    float n = nearFar.x, fr = nearFar.y;
    gl_Position = vec4((2.0 * K.x / viewport.x) * cur.x + (2.0 * K.z / viewport.x - 1.0) * cur.z,
                       -(2.0 * K.y / viewport.y) * cur.y + (1.0 - 2.0 * K.w / viewport.y) * cur.z,
                       (fr + n) / (fr - n) * cur.z - 2.0 * fr * n / (fr - n), cur.z);
  }
}`;

const EXACT_FS = /* glsl */ `
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D map;
uniform vec4 K;
uniform vec2 viewport;
uniform vec2 nearFar;
flat in vec3 c0;
flat in vec3 c1;
flat in vec3 c2;
flat in vec3 t0;
flat in vec3 t1;
flat in vec3 t2;
out vec4 fragColor;
bool lexLessEqual(vec3 a, vec3 b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z <= b.z;
}
vec3 edgeNormal(vec3 a, vec3 b) { return lexLessEqual(a, b) ? cross(a, b - a) : -cross(b, a - b); }
bool topLeft(vec3 n) { return n.x > 0.0 || (n.x == 0.0 && n.y > 0.0); }
vec3 texel(ivec2 p) { return texelFetch(map, p, 0).rgb; }
void main() {
  vec3 d = vec3((gl_FragCoord.x - K.z) / K.x, (viewport.y - gl_FragCoord.y - K.w) / K.y, 1.0);
  vec3 n0 = edgeNormal(c1, c2), n1 = edgeNormal(c2, c0), n2 = edgeNormal(c0, c1);
  vec3 N = cross(c1 - c0, c2 - c0);
  float det = dot(c0, N);
  if (!(abs(det) > 1e-6 * length(N) * length(c0))) discard;  // edge-on or degenerate
  float sg = det > 0.0 ? 1.0 : -1.0;
  n0 *= sg; n1 *= sg; n2 *= sg; N *= sg; det *= sg;
  float E0 = n0.x * d.x + n0.y * d.y + n0.z, E1 = n1.x * d.x + n1.y * d.y + n1.z, E2 = n2.x * d.x + n2.y * d.y + n2.z;
  if (E0 < 0.0 || (E0 == 0.0 && !topLeft(n0))) discard;
  if (E1 < 0.0 || (E1 == 0.0 && !topLeft(n1))) discard;
  if (E2 < 0.0 || (E2 == 0.0 && !topLeft(n2))) discard;
  float den = N.x * d.x + N.y * d.y + N.z;
  if (!(den > 0.0)) discard;
  float z = det / den;
  if (!(z >= nearFar.x && z <= nearFar.y)) discard;
  // The coverage cut: the interpolated coverage >= 0.5 (a face with every corner under it
  // draws nothing, one with none under it draws whole, as the C++ setup decides).
  if (E0 * (t0.z - 0.5) + E1 * (t1.z - 0.5) + E2 * (t2.z - 0.5) < 0.0) discard;
  float inv = 1.0 / (E0 + E1 + E2);
  vec2 uv = (E0 * inv) * t0.xy + (E1 * inv) * t1.xy + (E2 * inv) * t2.xy;
  // render/texture.h bilinear_tap (glTF v = 1 - v_smplx: y = v H - 0.5)
  ivec2 size = textureSize(map, 0);
  float x = clamp(uv.x * float(size.x) - 0.5, 0.0, float(size.x - 1));
  float y = clamp(uv.y * float(size.y) - 0.5, 0.0, float(size.y - 1));
  int x0 = min(int(x), size.x - 1), y0 = min(int(y), size.y - 1);
  int x1 = min(x0 + 1, size.x - 1), y1 = min(y0 + 1, size.y - 1);
  float fx = x - float(x0), fy = y - float(y0);
  vec3 c = (1.0 - fx) * (1.0 - fy) * texel(ivec2(x0, y0)) + fx * (1.0 - fy) * texel(ivec2(x1, y0)) +
           (1.0 - fx) * fy * texel(ivec2(x0, y1)) + fx * fy * texel(ivec2(x1, y1));
  fragColor = vec4(c, z);
  gl_FragDepth = (z - nearFar.x) / (nearFar.y - nearFar.x);
}`;

const SPLAT_VS = /* glsl */ `
precision highp float;
in vec4 rect;    // x0, y0, x1 + 1, y1 + 1 (pixels)
in vec4 meanConic; // mx, my, ca, cb
in vec4 params;  // cc, opacity, power_min, z
in vec4 color;
uniform vec2 viewport;
${splatVaryings('out')}
flat out float vZ;
${SPLAT_GLSL_VERTEX}
void main() {
  int corner = gl_VertexID % 4;  // 4 vertices per Gaussian (splat.js)
  vec2 pix = hahaSplatCorner(rect, corner);
  gl_Position = vec4(hahaPixelToClip(pix, viewport), 0.0, 1.0);
  hahaSplatVaryings(meanConic, params, color);
  vZ = params.w;
}`;

// render/gaussian_kernels.h pixel_alpha (splat.js) + gaussian_composite.h composite_step's depth test.
const SPLAT_FS = /* glsl */ `
precision highp float;
precision highp sampler2D;
uniform sampler2D meshTex;
uniform vec2 viewport;
uniform float margin;
${splatVaryings('in')}
flat in float vZ;
out vec4 fragColor;
${SPLAT_GLSL_FRAGMENT}
void main() {
  float alpha = hahaSplatAlpha(vec2(gl_FragCoord.x, viewport.y - gl_FragCoord.y));
  float D = texelFetch(meshTex, ivec2(gl_FragCoord.xy), 0).a;
  if (D > 0.0 && vZ > D + margin) discard;
  fragColor = vec4(vColor * alpha, alpha);
}`;

const COMPOSITE_VS = /* glsl */ `
in vec3 position;
void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }`;

const PRESENT_FS = /* glsl */ `
precision highp float;
precision highp sampler2D;
uniform sampler2D image;
out vec4 fragColor;
void main() { fragColor = vec4(texelFetch(image, ivec2(gl_FragCoord.xy), 0).rgb, 1.0); }`;

const COMPOSITE_FS = /* glsl */ `
precision highp float;
precision highp sampler2D;
uniform sampler2D meshTex;
uniform sampler2D accumTex;
uniform vec3 background;
uniform bool gaussians;
out vec4 fragColor;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec4 m = texelFetch(meshTex, p, 0);
  float mask = m.a > 0.0 ? 1.0 : 0.0;
  vec3 under = mask * m.rgb + (1.0 - mask) * background;
  vec4 g = gaussians ? texelFetch(accumTex, p, 0) : vec4(0.0);
  fragColor = vec4(g.rgb + (1.0 - g.a) * under, 1.0);
}`;

export class AvatarRenderer {
  constructor(canvas) {
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: false, preserveDrawingBuffer: true, depth: false, stencil: false });
    this.renderer.setPixelRatio(1);
    this.renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
    this.renderer.autoClear = false;
    const gl = this.renderer.getContext();
    this.gl = gl;
    // Blending into RGBA32F needs EXT_float_blend; without it the accumulation is half float.
    this.floatBlend = !!gl.getExtension('EXT_float_blend');
    this.camera = new THREE.Camera();
    this.camera.matrixWorldAutoUpdate = false;
    this.meshScene = new THREE.Scene();
    this.meshScene.matrixWorldAutoUpdate = true;
    this.meshMaterial = null;
    this.width = 0;
    this.height = 0;
    this.background = new THREE.Color(1, 1, 1);
    this.gaussians = true;
    this.margin = 0;
    this._buildSplatPass();
    this._buildCompositePass();
  }

  // A ShaderMaterial for the body: works on the CPU-skinned Mesh and on the glTF SkinnedMesh.
  // With `coverage` the body's COLOR_0 alpha (the mesh coverage) cuts it.
  meshMaterialFor(texture, coverage = false) {
    return new THREE.ShaderMaterial({
      vertexShader: MESH_VS, fragmentShader: MESH_FS, uniforms: { map: { value: texture } }, vertexColors: coverage,
      side: THREE.DoubleSide, depthFunc: THREE.LessDepth, blending: THREE.NoBlending,
    });
  }

  // The body mesh drawn by the exact pass: faces (F, 3) and uv (Vg, 2) as stored in the
  // glTF, the mesh coverage (Vg) or null; update(positions) uploads the posed glTF vertices
  // (Vg, 3) each frame.
  createExactMesh(faces, uv, numVerts, texture, coverage = null) {
    const F = faces.length / 3, width = 1024;
    const tex2d = (count, data, format, type) => {
      const t = new THREE.DataTexture(data, width, Math.max(1, Math.ceil(count / width)), format, type);
      t.minFilter = t.magFilter = THREE.NearestFilter;
      t.generateMipmaps = false;
      t.needsUpdate = true;
      return t;
    };
    const rows = (n) => width * Math.max(1, Math.ceil(n / width));
    const faceData = new Int32Array(4 * rows(F));
    for (let f = 0; f < F; f++) faceData.set([faces[3 * f], faces[3 * f + 1], faces[3 * f + 2], 0], 4 * f);
    const uvData = new Float32Array(4 * rows(numVerts));
    for (let v = 0; v < numVerts; v++) {
      uvData[4 * v] = uv[2 * v];
      uvData[4 * v + 1] = uv[2 * v + 1];
      uvData[4 * v + 2] = coverage ? coverage[v] : 1;
    }
    const posData = new Float32Array(4 * rows(numVerts));
    const posTex = tex2d(numVerts, posData, THREE.RGBAFormat, THREE.FloatType);
    const material = new THREE.RawShaderMaterial({
      glslVersion: THREE.GLSL3, vertexShader: EXACT_VS, fragmentShader: EXACT_FS,
      uniforms: {
        posTex: { value: posTex }, uvTex: { value: tex2d(numVerts, uvData, THREE.RGBAFormat, THREE.FloatType) },
        faceTex: { value: tex2d(F, faceData, THREE.RGBAIntegerFormat, THREE.IntType) }, map: { value: texture },
        camR: { value: new THREE.Matrix3() }, camT: { value: new THREE.Vector3() }, K: { value: new THREE.Vector4() },
        viewport: { value: new THREE.Vector2() }, nearFar: { value: new THREE.Vector2() },
      },
      side: THREE.DoubleSide, depthFunc: THREE.LessDepth, blending: THREE.NoBlending,
    });
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * F), 1));  // draw count only
    g.boundingSphere = new THREE.Sphere(new THREE.Vector3(), Infinity);
    const mesh = new THREE.Mesh(g, material);
    mesh.frustumCulled = false;
    mesh.onBeforeRender = () => {
      const c = this.cam, u = material.uniforms;
      u.camR.value.set(c.R[0], c.R[1], c.R[2], c.R[3], c.R[4], c.R[5], c.R[6], c.R[7], c.R[8]);
      u.camT.value.set(c.t[0], c.t[1], c.t[2]);
      u.K.value.set(c.fx, c.fy, c.cx, c.cy);
      u.viewport.value.set(c.width, c.height);
      u.nearFar.value.set(c.near, c.far);
    };
    mesh.update = (positions) => {
      for (let v = 0; v < numVerts; v++) {
        posData[4 * v] = positions[3 * v]; posData[4 * v + 1] = positions[3 * v + 1]; posData[4 * v + 2] = positions[3 * v + 2];
      }
      posTex.needsUpdate = true;
    };
    return mesh;
  }

  _buildSplatPass() {
    this.splatGeometry = new THREE.BufferGeometry();
    this.splatGeometry.boundingSphere = new THREE.Sphere(new THREE.Vector3(), Infinity);
    this._setSplatCapacity(1024);
    this.splatMaterial = new THREE.RawShaderMaterial({
      glslVersion: THREE.GLSL3, vertexShader: SPLAT_VS, fragmentShader: SPLAT_FS,
      uniforms: { meshTex: { value: null }, viewport: { value: new THREE.Vector2() }, margin: { value: 0 } },
      depthTest: false, depthWrite: false, transparent: true, side: THREE.DoubleSide,
      blending: THREE.CustomBlending, blendEquation: THREE.AddEquation,
      blendSrc: THREE.OneMinusDstAlphaFactor, blendDst: THREE.OneFactor,
      blendSrcAlpha: THREE.OneMinusDstAlphaFactor, blendDstAlpha: THREE.OneFactor,
    });
    const mesh = new THREE.Mesh(this.splatGeometry, this.splatMaterial);
    mesh.frustumCulled = false;
    this.splatScene = new THREE.Scene();
    this.splatScene.add(mesh);
  }

  _setSplatCapacity(n) {
    const g = this.splatGeometry;
    this.splatCapacity = n;
    this.splatData = new Float32Array(CORNERS * STRIDE * n);
    const buf = new THREE.InterleavedBuffer(this.splatData, STRIDE);
    buf.setUsage(THREE.DynamicDrawUsage);
    g.setIndex(new THREE.BufferAttribute(quadIndices(n), 1));
    this.splatBuffer = buf;
    g.setAttribute('rect', new THREE.InterleavedBufferAttribute(buf, 4, 0));
    g.setAttribute('meanConic', new THREE.InterleavedBufferAttribute(buf, 4, 4));
    g.setAttribute('params', new THREE.InterleavedBufferAttribute(buf, 4, 8));
    g.setAttribute('color', new THREE.InterleavedBufferAttribute(buf, 4, 12));
    g.setDrawRange(0, 0);
  }

  _buildCompositePass() {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(new Float32Array([-1, -1, 0, 3, -1, 0, -1, 3, 0]), 3));
    g.boundingSphere = new THREE.Sphere(new THREE.Vector3(), Infinity);
    this.compositeMaterial = new THREE.RawShaderMaterial({
      glslVersion: THREE.GLSL3, vertexShader: COMPOSITE_VS, fragmentShader: COMPOSITE_FS,
      uniforms: { meshTex: { value: null }, accumTex: { value: null }, background: { value: new THREE.Color() }, gaussians: { value: true } },
      depthTest: false, depthWrite: false, blending: THREE.NoBlending,
    });
    const mesh = new THREE.Mesh(g, this.compositeMaterial);
    mesh.frustumCulled = false;
    this.compositeScene = new THREE.Scene();
    this.compositeScene.add(mesh);
    this.presentMaterial = new THREE.RawShaderMaterial({
      glslVersion: THREE.GLSL3, vertexShader: COMPOSITE_VS, fragmentShader: PRESENT_FS,
      uniforms: { image: { value: null } }, depthTest: false, depthWrite: false, blending: THREE.NoBlending,
    });
    const pm = new THREE.Mesh(g, this.presentMaterial);
    pm.frustumCulled = false;
    this.presentScene = new THREE.Scene();
    this.presentScene.add(pm);
  }

  setSize(w, h) {
    if (w === this.width && h === this.height) return;
    this.width = w;
    this.height = h;
    this.renderer.setSize(w, h, false);
    if (this.meshTarget) { this.meshTarget.dispose(); this.accumTarget.dispose(); this.outTarget.dispose(); }
    const depthTexture = new THREE.DepthTexture(w, h, THREE.FloatType);
    this.meshTarget = new THREE.WebGLRenderTarget(w, h, {
      type: THREE.FloatType, format: THREE.RGBAFormat, minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter,
      depthBuffer: true, depthTexture, generateMipmaps: false,
    });
    this.accumTarget = new THREE.WebGLRenderTarget(w, h, {
      type: this.floatBlend ? THREE.FloatType : THREE.HalfFloatType, format: THREE.RGBAFormat,
      minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter, depthBuffer: false, generateMipmaps: false,
    });
    this.outTarget = new THREE.WebGLRenderTarget(w, h, {
      type: THREE.UnsignedByteType, format: THREE.RGBAFormat, minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter,
      depthBuffer: false, generateMipmaps: false,
    });
  }

  // cam: OpenCV camera (camera.js); splats: SplatProjector.out (CORNERS x STRIDE floats per
  // Gaussian, depth-sorted); count: number of Gaussians in it.
  render(cam, splats, count) {
    const r = this.renderer;
    this.cam = cam;
    this.setSize(cam.width, cam.height);
    // 1. mesh
    r.setRenderTarget(this.meshTarget);
    r.setClearColor(0x000000, 0);
    r.clear(true, true, false);
    r.render(this.meshScene, this.camera);
    // 2. splats
    r.setRenderTarget(this.accumTarget);
    r.setClearColor(0x000000, 0);
    r.clear(true, false, false);
    if (this.gaussians && count > 0) {
      if (count > this.splatCapacity) this._setSplatCapacity(Math.max(count, 2 * this.splatCapacity));
      this.splatData.set(splats.subarray(0, CORNERS * STRIDE * count));
      this.splatBuffer.clearUpdateRanges();
      this.splatBuffer.addUpdateRange(0, CORNERS * STRIDE * count);
      this.splatBuffer.needsUpdate = true;
      this.splatGeometry.setDrawRange(0, 6 * count);
      const u = this.splatMaterial.uniforms;
      u.meshTex.value = this.meshTarget.texture;
      u.viewport.value.set(cam.width, cam.height);
      u.margin.value = this.margin;
      r.render(this.splatScene, this.camera);
    }
    // 3. composite (8 bits), then to the canvas
    r.setRenderTarget(this.outTarget);
    const cu = this.compositeMaterial.uniforms;
    cu.meshTex.value = this.meshTarget.texture;
    cu.accumTex.value = this.accumTarget.texture;
    cu.background.value.copy(this.background);
    cu.gaussians.value = this.gaussians;
    r.render(this.compositeScene, this.camera);
  }

  present() {
    this.presentMaterial.uniforms.image.value = this.outTarget.texture;
    this.renderer.setRenderTarget(null);
    this.renderer.render(this.presentScene, this.camera);
  }

  // The rendered image as RGB bytes, rows top-down (waits for the GPU).
  readPixels() {
    const w = this.width, h = this.height;
    const rgba = new Uint8Array(4 * w * h);
    this.renderer.readRenderTargetPixels(this.outTarget, 0, 0, w, h, rgba);
    const rgb = new Uint8Array(3 * w * h);
    for (let y = 0; y < h; y++) {
      const src = 4 * w * (h - 1 - y), dst = 3 * w * y;
      for (let x = 0; x < w; x++) {
        rgb[dst + 3 * x] = rgba[src + 4 * x];
        rgb[dst + 3 * x + 1] = rgba[src + 4 * x + 1];
        rgb[dst + 3 * x + 2] = rgba[src + 4 * x + 2];
      }
    }
    return rgb;
  }

  // Waits until the GPU has drawn the image (a 1-pixel read of the 8-bit target).
  finish() {
    this.renderer.readRenderTargetPixels(this.outTarget, 0, 0, 1, 1, new Uint8Array(4));
  }
}
