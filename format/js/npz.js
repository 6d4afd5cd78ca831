// .npz (a zip of .npy arrays) and the two motion layouts `haha render` reads
// (libhaha/io/motion.h):
//   - AMASS-style, as `haha motion` writes: poses (T, 165) SMPL-X or (T, 156) SMPL+H,
//     trans (T, 3), mocap_frame_rate (or mocap_framerate / fps);
//   - native SMPL-X parameter files (global_orient, body_pose, jaw_pose, leye_pose,
//     reye_pose, left_hand_pose, right_hand_pose, transl; (D) or (N, D)), full axis-angle
//     hands only (PCA hands need the body model).
import { unzipSync } from 'fflate';

export const NUM_JOINTS = 55;
export const NUM_POSE = 165;

// One .npy: { shape, data: Float64Array | Int32Array ..., descr }.
export function parseNpy(bytes, name = 'array') {
  if (bytes[0] !== 0x93 || String.fromCharCode(...bytes.subarray(1, 6)) !== 'NUMPY') {
    throw new Error(`${name}: not a .npy array`);
  }
  const major = bytes[6];
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const hlen = major === 1 ? dv.getUint16(8, true) : dv.getUint32(8, true);
  const hstart = major === 1 ? 10 : 12;
  const header = new TextDecoder('latin1').decode(bytes.subarray(hstart, hstart + hlen));
  const descr = /'descr'\s*:\s*'([^']+)'/.exec(header)?.[1];
  const fortran = /'fortran_order'\s*:\s*True/.test(header);
  const shapeText = /'shape'\s*:\s*\(([^)]*)\)/.exec(header)?.[1];
  if (!descr || shapeText === undefined) throw new Error(`${name}: bad .npy header`);
  if (fortran) throw new Error(`${name}: Fortran-ordered arrays are not supported`);
  const shape = shapeText.split(',').map((s) => s.trim()).filter((s) => s.length).map(Number);
  const count = shape.reduce((a, b) => a * b, 1);
  const off = hstart + hlen;
  const raw = bytes.slice(off).buffer;  // aligned copy
  const little = descr[0] === '<' || descr[0] === '|' || descr[0] === '=';
  if (!little) throw new Error(`${name}: big-endian arrays are not supported`);
  const kind = descr.slice(1);
  const readers = {
    f4: () => new Float32Array(raw, 0, count), f8: () => new Float64Array(raw, 0, count),
    i4: () => new Int32Array(raw, 0, count), i8: () => Float64Array.from(new BigInt64Array(raw, 0, count), Number),
    u1: () => new Uint8Array(raw, 0, count), i2: () => new Int16Array(raw, 0, count),
  };
  if (!readers[kind]) throw new Error(`${name}: dtype ${descr} is not supported`);
  return { shape, data: Float64Array.from(readers[kind]()), descr };
}

export function parseNpz(buffer, name = 'file.npz') {
  const files = unzipSync(new Uint8Array(buffer));
  const out = {};
  for (const [k, v] of Object.entries(files)) {
    if (!k.endsWith('.npy')) continue;
    out[k.slice(0, -4)] = parseNpy(v, `${name}: ${k.slice(0, -4)}`);
  }
  return out;
}

function scalar(z, keys) {
  for (const k of keys) if (z[k]) return z[k].data[0];
  return undefined;
}

// -> { frames: [{ pose: Float64Array(165), transl: Float64Array(3) }], fps, up }
export function readMotion(buffer, name = 'motion.npz') {
  const z = parseNpz(buffer, name);
  const frames = [];
  if (z.poses) {
    const p = z.poses;
    if (p.shape.length !== 2 || (p.shape[1] !== 165 && p.shape[1] !== 156)) {
      throw new Error(`${name}: poses: shape (${p.shape}), expected (T, 165) SMPL-X or (T, 156) SMPL+H`);
    }
    const [T, D] = p.shape;
    const tr = z.trans;
    if (!tr || tr.shape.length !== 2 || tr.shape[0] !== T || tr.shape[1] !== 3) throw new Error(`${name}: trans: expected (${T}, 3)`);
    for (let f = 0; f < T; f++) {
      const pose = new Float64Array(NUM_POSE);
      const src = p.data.subarray(f * D, (f + 1) * D);
      if (D === 156) {  // SMPL+H: root + 21 body joints, then 2 x 15 hand joints; no jaw / eyes
        pose.set(src.subarray(0, 66), 0);
        pose.set(src.subarray(66, 156), 3 * 25);
      } else {
        pose.set(src);
      }
      frames.push({ pose, transl: Float64Array.from(tr.data.subarray(3 * f, 3 * f + 3)) });
    }
    const fps = scalar(z, ['mocap_frame_rate', 'mocap_framerate', 'fps']);
    if (!(fps > 0)) throw new Error(`${name}: no frame rate (mocap_frame_rate or mocap_framerate)`);
    // World up of the file: AMASS is Z-up unless an `up` array says otherwise (haha motion: +Y).
    const up = z.up ? Array.from(z.up.data) : [0, 0, 1];
    return { frames, fps, kind: 'amass', up };
  }
  // Native parameter file: (key, first joint, joint count).
  const parts = [['global_orient', 0, 1], ['body_pose', 1, 21], ['jaw_pose', 22, 1], ['leye_pose', 23, 1],
    ['reye_pose', 24, 1], ['left_hand_pose', 25, 15], ['right_hand_pose', 40, 15]];
  let T = 0;
  const rows = (key, d) => {
    const a = z[key];
    if (!a) return 0;
    if (a.data.length % d !== 0) throw new Error(`${name}: ${key}: ${a.data.length} values, not a multiple of ${d}`);
    return a.data.length / d;
  };
  for (const [k, , n] of parts) T = Math.max(T, rows(k, 3 * n));
  T = Math.max(T, rows('transl', 3));
  if (T === 0) throw new Error(`${name}: neither poses (AMASS) nor SMPL-X parameter arrays`);
  for (let f = 0; f < T; f++) frames.push({ pose: new Float64Array(NUM_POSE), transl: new Float64Array(3) });
  for (const [k, j0, n] of parts) {
    const a = z[k];
    if (!a) continue;
    const d = 3 * n, r = a.data.length / d;
    if (r !== T && r !== 1) throw new Error(`${name}: ${k}: ${r} rows, expected ${T}`);
    for (let f = 0; f < T; f++) frames[f].pose.set(a.data.subarray((r === 1 ? 0 : f) * d, (r === 1 ? 1 : f + 1) * d), 3 * j0);
  }
  if (z.transl) {
    const r = z.transl.data.length / 3;
    for (let f = 0; f < T; f++) frames[f].transl.set(z.transl.data.subarray((r === 1 ? 0 : f) * 3, (r === 1 ? 1 : f + 1) * 3));
  }
  return { frames, fps: scalar(z, ['mocap_frame_rate', 'mocap_framerate', 'fps']) || 30, kind: 'params', up: [0, 1, 0] };
}

// Rodrigues: axis-angle -> row-major 3 x 3.
function rodrigues(w) {
  const t = Math.hypot(w[0], w[1], w[2]);
  if (t < 1e-12) return [1, 0, 0, 0, 1, 0, 0, 0, 1];
  const [x, y, z] = [w[0] / t, w[1] / t, w[2] / t], c = Math.cos(t), s = Math.sin(t), C = 1 - c;
  return [c + x * x * C, x * y * C - z * s, x * z * C + y * s,
    y * x * C + z * s, c + y * y * C, y * z * C - x * s,
    z * x * C - y * s, z * y * C + x * s, c + z * z * C];
}
const mul = (a, b) => Array.from({ length: 9 }, (_, i) => a[3 * Math.floor(i / 3)] * b[i % 3] +
  a[3 * Math.floor(i / 3) + 1] * b[3 + i % 3] + a[3 * Math.floor(i / 3) + 2] * b[6 + i % 3]);
const apply = (m, v) => [0, 1, 2].map((r) => m[3 * r] * v[0] + m[3 * r + 1] * v[1] + m[3 * r + 2] * v[2]);

// Matrix -> axis-angle through the quaternion (w >= 0), angle in [0, pi].
function axisAngle(m) {
  const tr = m[0] + m[4] + m[8];
  let q;
  if (tr > 0) {
    const s = 2 * Math.sqrt(tr + 1);
    q = [s / 4, (m[7] - m[5]) / s, (m[2] - m[6]) / s, (m[3] - m[1]) / s];
  } else if (m[0] > m[4] && m[0] > m[8]) {
    const s = 2 * Math.sqrt(1 + m[0] - m[4] - m[8]);
    q = [(m[7] - m[5]) / s, s / 4, (m[1] + m[3]) / s, (m[2] + m[6]) / s];
  } else if (m[4] > m[8]) {
    const s = 2 * Math.sqrt(1 + m[4] - m[0] - m[8]);
    q = [(m[2] - m[6]) / s, (m[1] + m[3]) / s, s / 4, (m[5] + m[7]) / s];
  } else {
    const s = 2 * Math.sqrt(1 + m[8] - m[0] - m[4]);
    q = [(m[3] - m[1]) / s, (m[2] + m[6]) / s, (m[5] + m[7]) / s, s / 4];
  }
  if (q[0] < 0) q = q.map((v) => -v);
  const n = Math.hypot(q[1], q[2], q[3]);
  if (n < 1e-12) return [2 * q[1], 2 * q[2], 2 * q[3]];
  const a = 2 * Math.atan2(n, q[0]) / n;
  return [a * q[1], a * q[2], a * q[3]];
}

// The C++ motion_to_y_up (io/motion.h): turns every frame by the smallest rotation taking
// motion.up to +Y about the world origin: root' = R root, transl' = R (J0 + transl) - J0,
// J0 = the avatar's rest pelvis.
export function motionToYUp(motion, pelvis) {
  const u = motion.up || [0, 1, 0], n = Math.hypot(u[0], u[1], u[2]);
  const up = [u[0] / n, u[1] / n, u[2] / n];
  const axis = [-up[2], 0, up[0]];  // up x (0, 1, 0)
  const s = Math.hypot(axis[0], axis[1], axis[2]), c = up[1];
  if (s < 1e-12 && c > 0) return motion;
  const w = s < 1e-12 ? [Math.PI, 0, 0] : axis.map((v) => v * Math.atan2(s, c) / s);
  const R = rodrigues(w);
  for (const f of motion.frames) {
    const root = axisAngle(mul(R, rodrigues([f.pose[0], f.pose[1], f.pose[2]])));
    const t = apply(R, [pelvis[0] + f.transl[0], pelvis[1] + f.transl[1], pelvis[2] + f.transl[2]]);
    f.pose.set(root, 0);
    f.transl.set([t[0] - pelvis[0], t[1] - pelvis[1], t[2] - pelvis[2]]);
  }
  motion.up = [0, 1, 0];
  return motion;
}
