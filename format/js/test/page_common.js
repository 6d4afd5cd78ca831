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
