// OpenCV pinhole cameras (docs/architecture.md "Conventions", io/camera_json.h) <-> three.js matrices.
//
// cam.json: {"width":W,"height":H,"K":[[fx,0,cx],[0,fy,cy],[0,0,1]],
//            "world_to_camera":[[..4..] x 4],"near":0.01,"far":100}
// Pixel (i, j) covers [i, i+1) x [j, j+1); its centre is (i + 0.5, j + 0.5). With the
// projection below, WebGL's window coordinates are x_win = u, y_win = H - v for the OpenCV
// pixel coordinates (u, v), so gl_FragCoord (pixel centres at +0.5) samples exactly the
// C++ rasterizers' pixel centres.
import * as THREE from 'three';

export function parseCameraJson(obj, where = 'camera') {
  const fail = (m) => { throw new Error(`${where}: ${m}`); };
  const W = obj.width, H = obj.height, K = obj.K, E = obj.world_to_camera;
  if (!Number.isInteger(W) || !Number.isInteger(H) || W < 1 || H < 1) fail('width/height must be positive integers');
  if (!Array.isArray(K) || K.length !== 3 || !Array.isArray(E) || E.length < 3) fail('K (3 x 3) and world_to_camera (4 x 4) required');
  const R = [E[0][0], E[0][1], E[0][2], E[1][0], E[1][1], E[1][2], E[2][0], E[2][1], E[2][2]];
  return {
    width: W, height: H, fx: K[0][0], fy: K[1][1], cx: K[0][2], cy: K[1][2],
    R, t: [E[0][3], E[1][3], E[2][3]], near: obj.near ?? 0.01, far: obj.far ?? 100,
  };
}

export function cameraToJson(c) {
  return {
    width: c.width, height: c.height,
    K: [[c.fx, 0, c.cx], [0, c.fy, c.cy], [0, 0, 1]],
    world_to_camera: [[c.R[0], c.R[1], c.R[2], c.t[0]], [c.R[3], c.R[4], c.R[5], c.t[1]], [c.R[6], c.R[7], c.R[8], c.t[2]], [0, 0, 0, 1]],
    near: c.near, far: c.far,
  };
}

// render_run.cpp framing_camera(): a front camera looking along world -Z framing [lo, hi].
export function framingCamera(lo, hi, size) {
  const f = 1.5 * size;
  const centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
  const half = 0.5 * Math.max(hi[0] - lo[0], hi[1] - lo[1]) * 1.15;
  const dist = half * f / (0.5 * size) + 0.5 * (hi[2] - lo[2]);
  const R = [1, 0, 0, 0, -1, 0, 0, 0, -1];
  const eye = [centre[0], centre[1], centre[2] + dist];
  const t = [-eye[0], eye[1], eye[2]];  // -(R eye)
  return { width: size, height: size, fx: f, fy: f, cx: 0.5 * size, cy: 0.5 * size, R, t, near: 0.01, far: dist * 4 + 10, centre, eye };
}

// Sets a three.js Camera (matrixAutoUpdate off) to the OpenCV camera c: the view matrix is
// diag(1, -1, -1) [R | t] (three.js cameras look along -z with y up), the projection maps
// camera z in [near, far] to clip space and pixel (u, v) to NDC (2u/W - 1, 1 - 2v/H).
export function applyToThree(c, cam3) {
  const { width: W, height: H, fx, fy, cx, cy, R, t, near: n, far: f } = c;
  const view = new THREE.Matrix4().set(
    R[0], R[1], R[2], t[0],
    -R[3], -R[4], -R[5], -t[1],
    -R[6], -R[7], -R[8], -t[2],
    0, 0, 0, 1);
  cam3.matrixAutoUpdate = false;
  cam3.matrix.copy(view).invert();
  cam3.matrixWorldNeedsUpdate = true;
  cam3.updateMatrixWorld(true);
  cam3.matrixWorldInverse.copy(view);
  cam3.projectionMatrix.set(
    2 * fx / W, 0, 1 - 2 * cx / W, 0,
    0, 2 * fy / H, 2 * cy / H - 1, 0,
    0, 0, -(f + n) / (f - n), -2 * f * n / (f - n),
    0, 0, -1, 0);
  cam3.projectionMatrixInverse.copy(cam3.projectionMatrix).invert();
}

// The OpenCV camera of a three.js PerspectiveCamera (orbit controls) at W x H pixels.
export function fromPerspective(p, W, H) {
  p.updateMatrixWorld();
  const e = p.matrixWorldInverse.elements;  // column-major
  const fy = 0.5 * H / Math.tan(THREE.MathUtils.degToRad(p.fov) / 2);
  return {
    width: W, height: H, fx: fy, fy, cx: 0.5 * W, cy: 0.5 * H,
    R: [e[0], e[4], e[8], -e[1], -e[5], -e[9], -e[2], -e[6], -e[10]],
    t: [e[12], -e[13], -e[14]], near: p.near, far: p.far,
  };
}
