// Helpers shared by the test pages (engine-free; THREE passed in where needed).

// Sets SMPL-X axis-angle joint rotations on an engine's 55 bones (quaternion x, y, z, w via
// setQuat) and the root translation: joint j's local rotation = pose[3j..3j+2].
export function axisAngleQuat(wx, wy, wz) {
  const t = Math.hypot(wx, wy, wz);
  if (t === 0) return [0, 0, 0, 1];
  const s = Math.sin(t / 2) / t;
  return [wx * s, wy * s, wz * s, Math.cos(t / 2)];
}

export function poseBones(THREE, bones, pose, transl, rootRest) {
  for (let j = 0; j < 55; j++) {
    const [x, y, z, w] = axisAngleQuat(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]);
    bones[j].quaternion.set(x, y, z, w);
  }
  bones[0].position.set(rootRest.x + transl[0], rootRest.y + transl[1], rootRest.z + transl[2]);
}

// The 4 x 4 view (OpenGL: camera looks along -z) and projection matrices of an OpenCV camera
// (cam.json, README "Conventions"), as column-major arrays: pixel (u, v) -> NDC (2u/W - 1, 1 - 2v/H).
export function glMatrices(cam) {
  const E = cam.world_to_camera, K = cam.K, W = cam.width, H = cam.height;
  const n = cam.near ?? 0.01, f = cam.far ?? 100;
  const view = [  // rows of diag(1, -1, -1) [R | t], stored column-major
    E[0][0], -E[1][0], -E[2][0], 0,
    E[0][1], -E[1][1], -E[2][1], 0,
    E[0][2], -E[1][2], -E[2][2], 0,
    E[0][3], -E[1][3], -E[2][3], 1];
  const fx = K[0][0], fy = K[1][1], cx = K[0][2], cy = K[1][2];
  const proj = [
    2 * fx / W, 0, 0, 0,
    0, 2 * fy / H, 0, 0,
    1 - 2 * cx / W, 2 * cy / H - 1, -(f + n) / (f - n), -1,
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
