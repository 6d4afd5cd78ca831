// The harness shared by the test pages (page.html?engine=three|babylon|spark): the engine's
// module (<engine>_page.js) exports the page's API, window.hahaTest, built from these helpers
// (engine-free; THREE passed in where needed).

// three's Draco decoder, served locally (format/js/node_modules).
export const DRACO_PATH = '/node_modules/three/examples/jsm/libs/draco/';

// A three.js page: its renderer on the page's canvas (no antialiasing, the drawing buffer kept
// for readPixels), a scene on black, a camera (set by applyOpenCvCamera) and a DRACOLoader.
export function threeApp(THREE, DRACOLoader) {
  const canvas = document.getElementById('view');
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0, 0, 0);
  return { renderer, scene, camera: new THREE.PerspectiveCamera(), draco: new DRACOLoader().setDecoderPath(DRACO_PATH) };
}

// SMPL-X axis-angle joint rotations as quaternions (x, y, z, w): joint j's local rotation is
// pose[3j..3j+2].
export function axisAngleQuat(wx, wy, wz) {
  const t = Math.hypot(wx, wy, wz);
  if (t === 0) return [0, 0, 0, 1];
  const s = Math.sin(t / 2) / t;
  return [wx * s, wy * s, wz * s, Math.cos(t / 2)];
}

export function jointQuats(pose) {
  const q = [];
  for (let j = 0; j < 55; j++) q.push(axisAngleQuat(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]));
  return q;
}

// The root joint's position: its rest position (x, y, z) plus the translation.
export function rootPosition(rest, transl) {
  return [rest.x + transl[0], rest.y + transl[1], rest.z + transl[2]];
}

// Sets a pose on an engine's 55 bones (bone.quaternion, bone.position: three.js) by hand.
export function poseBones(THREE, bones, pose, transl, rootRest) {
  jointQuats(pose).forEach(([x, y, z, w], j) => bones[j].quaternion.set(x, y, z, w));
  bones[0].position.set(...rootPosition(rootRest, transl));
}

// The 4 x 4 view and projection matrices of an OpenCV camera (cam.json, README "Conventions"),
// column-major: pixel (u, v) -> NDC (2u/W - 1, 1 - 2v/H). Right-handed (OpenGL, three.js,
// Babylon with useRightHandedSystem): the camera looks along -z. leftHanded (Babylon's
// default): the camera looks along +z, and the world is the glTF frame mirrored in x (the
// loader's __root__ node: 180 degrees about y, z scaled by -1).
export function glMatrices(cam, leftHanded = false) {
  const E = cam.world_to_camera, K = cam.K, W = cam.width, H = cam.height;
  const n = cam.near ?? 0.01, f = cam.far ?? 100;
  const fx = K[0][0], fy = K[1][1], cx = K[0][2], cy = K[1][2];
  const sz = leftHanded ? 1 : -1, mx = leftHanded ? -1 : 1;  // view z sign; mirror of world x
  const view = [  // rows of diag(1, -1, sz) [R | t] diag(mx, 1, 1, 1), stored column-major
    mx * E[0][0], -mx * E[1][0], sz * mx * E[2][0], 0,
    E[0][1], -E[1][1], sz * E[2][1], 0,
    E[0][2], -E[1][2], sz * E[2][2], 0,
    E[0][3], -E[1][3], sz * E[2][3], 1];
  const proj = [
    2 * fx / W, 0, 0, 0,
    0, 2 * fy / H, 0, 0,
    -sz * (1 - 2 * cx / W), -sz * (2 * cy / H - 1), sz * (f + n) / (f - n), sz,
    0, 0, -2 * f * n / (f - n), 0];
  return { view, proj };
}

export function applyOpenCvCamera(cam, cam3) {
  const { view, proj } = glMatrices(cam);
  cam3.matrixAutoUpdate = false;
  cam3.matrixWorldInverse.fromArray(view);
  cam3.matrix.copy(cam3.matrixWorldInverse).invert();
  cam3.matrixWorld.copy(cam3.matrix);
  cam3.projectionMatrix.fromArray(proj);
  cam3.projectionMatrixInverse.copy(cam3.projectionMatrix).invert();
  cam3.updateProjectionMatrix = () => {};  // keep ours
  cam3.updateMatrixWorld = () => {};
}

export function toBase64(bytes) {
  let s = '';
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}

// The bytes of a typed array as base64.
export const typedBase64 = (a) => toBase64(new Uint8Array(a.buffer, a.byteOffset, a.byteLength));

// The drawing buffer's RGBA bytes (rows bottom-up), and as RGB rows top-down.
export function readRgba(gl, width, height, rgba = new Uint8Array(4 * width * height)) {
  gl.readPixels(0, 0, width, height, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
  return rgba;
}

export function topDownRgb(rgba, width, height) {
  const rgb = new Uint8Array(3 * width * height);
  for (let y = 0; y < height; y++) for (let x = 0; x < width; x++) for (let c = 0; c < 3; c++) {
    rgb[3 * (y * width + x) + c] = rgba[4 * ((height - 1 - y) * width + x) + c];
  }
  return rgb;
}

// draw() (the engine renders the scene for cam), then the image: { rgb (base64, rows
// top-down), ms (draw and read back) }.
export function renderAndRead(gl, cam, draw) {
  const t0 = performance.now();
  draw();
  const rgba = readRgba(gl, cam.width, cam.height);
  const ms = performance.now() - t0;
  return { rgb: toBase64(topDownRgb(rgba, cam.width, cam.height)), ms };
}

// What load() reports of the loaded avatar (avatar.js Avatar), t0: when loading began.
export function avatarInfo(a, t0) {
  return { N: a.N, V: a.V, Vg: a.Vg, version: a.version, draco: a.meshDraco, faceOrder: a.faceOrder, poseCorrectives: !!a.posedirs, loadMs: performance.now() - t0 };
}

// The centroid (N x 3) of each Gaussian's face as the engine skins the body: skinnedAt(g) is
// the engine's world position [x, y, z] of glTF vertex g (the first of each body vertex).
export function faceCentroids(a, skinnedAt) {
  const gOf = new Int32Array(a.V).fill(-1);
  for (let g = 0; g < a.Vg; g++) if (gOf[a.bodyVertex[g]] < 0) gOf[a.bodyVertex[g]] = g;
  const cen = new Float64Array(3 * a.N), cache = new Map();
  const at = (g) => {
    if (!cache.has(g)) cache.set(g, skinnedAt(g));
    return cache.get(g);
  };
  for (let i = 0; i < a.N; i++) {
    const f = a.gFace[i];
    for (let k = 0; k < 3; k++) {
      const p = at(gOf[a.faces[3 * f + k]]);
      for (let c = 0; c < 3; c++) cen[3 * i + c] += p[c] / 3;
    }
  }
  return cen;
}

// centres(): the layer's world Gaussian centres and their faces' skinned centroids, base64 float64.
export const centresBase64 = (means, centroids) => ({ means: typedBase64(means), centroids: typedBase64(centroids) });
