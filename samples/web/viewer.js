// HAHA avatar viewer: loads a packed avatar (.glb, format/spec.md) with three.js's GLTFLoader
// and the HAHA_gaussian_avatar plugin (format/js/three), plays a motion (.npz from `haha
// motion`, AMASS or native SMPL-X parameters) by setting the skeleton's bones, and renders the
// textured mesh plus the face-bound Gaussians the plugin reposes from those bones exactly like
// `haha render` (lib/renderer.js: the merged renderer; format/js/splat.js).
//
// URL parameters (all optional except avatar):
//   avatar=URL      the .glb                    motion=URL    the .npz (default: rest pose)
//   camera=URL      cam.json (OpenCV, docs/architecture.md "Conventions"): fixed camera, same pixels as
//                   `haha render --camera`; otherwise a framing camera + orbit controls
//   size=PX         canvas size without camera= (default 512)
//   frame=I         start at frame I           play=0        start paused
//   gaussians=0     Gaussian layer off         bg=r,g,b      background in [0, 1] (default 1,1,1)
//   skin=gltf       show the body skinned by three.js from the glTF skin (GPU, 4 influences)
//                   instead of the loader's exact LBS (all influences, as the C++ runtime)
//   loop=0          no animation loop: render only through window.hahaViewer (tests)
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { NUM_JOINTS } from '../../format/js/avatar.js';
import { motionToYUp, readMotion } from '../../format/js/npz.js';
import { SplatProjector } from '../../format/js/splat.js';
import { HahaGaussianAvatarPlugin } from '../../format/js/three/HahaGaussianAvatarPlugin.js';
import { AvatarRenderer } from './lib/renderer.js';
import { parseCameraJson, cameraToJson, framingCamera, applyToThree, fromPerspective } from './lib/camera.js';

const params = new URLSearchParams(location.search);
const $ = (id) => document.getElementById(id);
const status = (msg) => { $('status').textContent = msg; };

async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
  return r.arrayBuffer();
}

async function textureOf(avatar) {
  let tex;
  if (avatar.textureExact) {  // lossless packs: the trained float texture
    const { width, height, data } = avatar.textureExact;
    const rgba = new Float32Array(4 * width * height);
    for (let i = 0; i < width * height; i++) {
      rgba[4 * i] = data[3 * i]; rgba[4 * i + 1] = data[3 * i + 1]; rgba[4 * i + 2] = data[3 * i + 2]; rgba[4 * i + 3] = 1;
    }
    tex = new THREE.DataTexture(rgba, width, height, THREE.RGBAFormat, THREE.FloatType);
  } else {
    // Decoded without colour management: the stored 8-bit values are the trained colours.
    const blob = new Blob([avatar.textureBytes], { type: avatar.textureMime });
    const bmp = await createImageBitmap(blob, { colorSpaceConversion: 'none', premultiplyAlpha: 'none', imageOrientation: 'none' });
    tex = new THREE.Texture(bmp);
  }
  tex.flipY = false;           // row 0 = top of the image (glTF UVs have their origin top-left)
  tex.colorSpace = THREE.NoColorSpace;
  tex.generateMipmaps = false;
  tex.minFilter = tex.magFilter = THREE.NearestFilter;  // sampled with texelFetch
  tex.needsUpdate = true;
  return tex;
}

class Viewer {
  constructor() {
    this.canvas = $('view');
    this.r = new AvatarRenderer(this.canvas);
    this.frame = Number(params.get('frame') || 0);
    this.playing = params.get('play') !== '0';
    this.skinMode = params.get('skin') === 'gltf' ? 'gltf' : 'exact';
    this.r.gaussians = params.get('gaussians') !== '0';
    const bg = (params.get('bg') || '1,1,1').split(',').map(Number);
    this.r.background.setRGB(bg[0], bg[1], bg[2], THREE.LinearSRGBColorSpace);
    this.stats = { repose: 0, project: 0, total: 0, visible: 0 };
    this.dirty = true;
  }

  async load() {
    const avatarUrl = params.get('avatar');
    if (!avatarUrl) throw new Error('no avatar: open this page with ?avatar=URL (serve.mjs does)');
    status(`loading ${avatarUrl} ...`);
    const [glbBytes, motionBytes, camJson] = await Promise.all([
      fetchBytes(avatarUrl),
      params.get('motion') ? fetchBytes(params.get('motion')) : null,
      params.get('camera') ? fetch(params.get('camera')).then((r) => r.json()) : null,
    ]);
    const draco = new DRACOLoader().setDecoderPath('node_modules/three/examples/jsm/libs/draco/');
    const t0 = performance.now();
    // GLTFLoader + the plugin: the skinned, textured body and the Gaussian layer (reposed
    // from the bones; drawn here by the merged renderer, so the layer itself stays hidden).
    const loader = new GLTFLoader().setDRACOLoader(draco);
    loader.register((parser) => new HahaGaussianAvatarPlugin(parser, { dracoLoader: draco, name: avatarUrl }));
    const gltf = await loader.parseAsync(glbBytes, '');
    this.layer = gltf.userData.hahaAvatar;
    if (!this.layer) throw new Error(`${avatarUrl}: not a HAHA avatar (no HAHA_gaussian_avatar extension)`);
    this.layer.visible = false;
    this.avatar = this.layer.avatar;
    const a = this.avatar;
    this.r.margin = a.depthMargin;
    this.motion = motionBytes ? readMotion(motionBytes, params.get('motion'))
      : { frames: [{ pose: new Float64Array(165), transl: new Float64Array(3) }], fps: 30, kind: 'rest' };
    motionToYUp(this.motion, a.restJoints.subarray(0, 3));  // AMASS (Z-up) stands upright
    this.frame = ((this.frame % this.motion.frames.length) + this.motion.frames.length) % this.motion.frames.length;

    const skinned = this.layer.skinnedMesh;
    const parts = this.layer.bodyParts;  // the body's primitive, then a garment's
    gltf.scene.traverse((o) => {
      if ((o.isMesh || o.isPoints) && !parts.includes(o) && o !== this.layer) o.visible = false;  // e.g. the optional KHR_gaussian_splatting points
    });
    this.gltfScene = gltf.scene;
    this.bones = skinned.skeleton.bones;
    this.rootRest = this.bones[0].position.clone();
    this.texture = await textureOf(a);
    const material = this.r.meshMaterialFor(this.texture, !!a.meshCoverage);
    for (const part of parts) {
      part.material = material;
      part.frustumCulled = false;
    }
    this.skinned = parts;

    // Exact path: CPU LBS of the loader, written into the glTF vertices through BODY_VERTEX.
    this.positions = new Float32Array(3 * a.Vg);
    // The mesh coverage per glTF vertex (its body vertex's), for the exact pass's cut.
    const coverage = a.meshCoverage ? Float32Array.from(a.bodyVertex, (b) => a.meshCoverage[b]) : null;
    this.exactMesh = this.r.createExactMesh(a.gltfFaces, a.uv, a.Vg, this.texture, coverage);
    this.r.meshScene.add(gltf.scene, this.exactMesh);
    this.projector = new SplatProjector(a.N);
    this.loadMs = performance.now() - t0;

    // Camera: fixed from cam.json, or framing the motion with orbit controls.
    if (camJson) {
      this.fixedCamera = parseCameraJson(camJson, params.get('camera'));
    } else {
      const size = Number(params.get('size') || 512);
      const c = this.framingCamera(size, 48);
      const p = new THREE.PerspectiveCamera(2 * THREE.MathUtils.radToDeg(Math.atan(0.5 * size / c.fy)), 1, c.near, c.far);
      p.position.set(c.eye[0], c.eye[1], c.eye[2]);
      this.orbitCam = p;
      this.orbitSize = size;
      this.controls = new OrbitControls(p, this.canvas);
      this.controls.target.set(c.centre[0], c.centre[1], c.centre[2]);
      this.controls.update();
      this.controls.addEventListener('change', () => { this.dirty = true; });
    }
    this._ui();
    status(`${avatarUrl}: ${a.V} vertices, ${a.F} faces, ${a.N} Gaussians` +
           `${a.posedirs ? ', pose correctives' : (a.trainedWithPoseCorrectives ? ' (trained with pose correctives, none embedded)' : '')}; ` +
           `${this.motion.frames.length} frames at ${this.motion.fps} fps; loaded in ${this.loadMs.toFixed(0)} ms`);
  }

  // render_run.cpp's default camera: a front view framing the motion (at most maxFrames
  // frames sampled evenly; all by default, as haha render does).
  framingCamera(size, maxFrames = Infinity) {
    const a = this.avatar, T = this.motion.frames.length;
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    const step = Math.max(1, Math.floor(T / Math.min(T, maxFrames)));
    for (let f = 0; f < T; f += step) {
      const { pose, transl } = this.motion.frames[f];
      a.reposeBody(pose, transl);
      for (let v = 0; v < a.V; v++) for (let k = 0; k < 3; k++) {
        lo[k] = Math.min(lo[k], a.posed[3 * v + k]);
        hi[k] = Math.max(hi[k], a.posed[3 * v + k]);
      }
    }
    return framingCamera(lo, hi, size);
  }

  // glTF skin: joint j's local rotation = the axis-angle pose[3j..3j+2]; root += transl.
  setBones(pose, transl) {
    const axis = new THREE.Vector3();
    for (let j = 0; j < NUM_JOINTS; j++) {
      axis.set(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]);
      const angle = axis.length();
      if (angle > 0) this.bones[j].quaternion.setFromAxisAngle(axis.divideScalar(angle), angle);
      else this.bones[j].quaternion.identity();
    }
    this.bones[0].position.set(this.rootRest.x + transl[0], this.rootRest.y + transl[1], this.rootRest.z + transl[2]);
  }

  currentCamera() {
    return this.fixedCamera || fromPerspective(this.orbitCam, this.orbitSize, this.orbitSize);
  }

  // Repose + render one frame; returns the timings (ms). sync: wait for the GPU (timing,
  // tests); the interactive loop does not, its frame rate is the measure there.
  renderFrame(sync = true) {
    const a = this.avatar, t0 = performance.now();
    const { pose, transl } = this.motion.frames[this.frame];
    this.setBones(pose, transl);
    this.gltfScene.updateMatrixWorld(true);  // the plugin's layer reposes from the bones
    this.layer.update();
    this.exactMesh.update(a.posedGltfVertices(this.positions));
    for (const part of this.skinned) part.visible = this.skinMode === 'gltf';
    this.exactMesh.visible = this.skinMode === 'exact';
    const t1 = performance.now();
    const cam = this.currentCamera();
    applyToThree(cam, this.r.camera);
    const n = this.r.gaussians ? this.projector.project(cam, a.N, a.means, a.quats, a.scales, a.gOpacity, a.gColor) : 0;
    const t2 = performance.now();
    this.r.render(cam, this.projector.out, n);
    if (sync) this.r.finish();
    const t3 = performance.now();
    this.r.present();
    this.stats = { repose: t1 - t0, project: t2 - t1, gpu: t3 - t2, total: t3 - t0, visible: n };
    return this.stats;
  }

  _ui() {
    const T = this.motion.frames.length;
    const slider = $('frame');
    slider.max = String(T - 1);
    slider.value = String(this.frame);
    slider.oninput = () => { this.frame = Number(slider.value); this.playing = false; this.dirty = true; this._sync(); };
    $('play').onclick = () => { this.playing = !this.playing; this._t0 = performance.now() - this.frame * 1000 / this.motion.fps; this._sync(); };
    $('gaussians').checked = this.r.gaussians;
    $('gaussians').onchange = (e) => { this.r.gaussians = e.target.checked; this.dirty = true; };
    $('skin').value = this.skinMode;
    $('skin').onchange = (e) => { this.skinMode = e.target.value; this.dirty = true; };
    this._sync();
  }

  _sync() {
    $('play').textContent = this.playing ? 'Pause' : 'Play';
    $('frame').value = String(this.frame);
    $('frameLabel').textContent = `${this.frame + 1} / ${this.motion.frames.length}`;
  }

  loop() {
    this._t0 = performance.now() - this.frame * 1000 / this.motion.fps;
    let fpsCount = 0, fpsT = performance.now(), fps = 0;
    const tick = () => {
      if (this.playing && this.motion.frames.length > 1) {
        const f = Math.floor((performance.now() - this._t0) * this.motion.fps / 1000) % this.motion.frames.length;
        if (f !== this.frame) { this.frame = f; this.dirty = true; this._sync(); }
      }
      if (this.dirty) {
        this.dirty = false;
        const s = this.renderFrame(false);
        fpsCount++;
        const now = performance.now();
        if (now - fpsT > 1000) { fps = fpsCount * 1000 / (now - fpsT); fpsCount = 0; fpsT = now; }
        $('timing').textContent = `CPU ${(s.repose + s.project).toFixed(1)} ms per frame (repose ${s.repose.toFixed(1)}, ` +
          `project+sort ${s.project.toFixed(1)}), ${s.visible} splats drawn, ${fps.toFixed(0)} frames/s`;
      }
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  }
}

// Test and scripting hooks (samples/web/test/viewer_test.mjs).
const viewer = new Viewer();
window.hahaViewer = {
  viewer,
  ready: viewer.load().then(() => {
    if (params.get('loop') !== '0') viewer.loop();
    return { vertices: viewer.avatar.V, faces: viewer.avatar.F, gaussians: viewer.avatar.N, frames: viewer.motion.frames.length,
             floatBlend: viewer.r.floatBlend, loadMs: viewer.loadMs, poseCorrectives: !!viewer.avatar.posedirs };
  }).catch((e) => { status(`error: ${e.message}`); console.error(e); throw e; }),
  setFrame(i) { viewer.frame = i; viewer.playing = false; viewer.dirty = true; },
  setGaussians(on) { viewer.r.gaussians = on; viewer.dirty = true; },
  setSkin(mode) { viewer.skinMode = mode; viewer.dirty = true; },
  render() { return viewer.renderFrame(); },
  // cam.json of the default framing camera (size x size) over the whole motion.
  framingCamera(size = 512) { return cameraToJson(viewer.framingCamera(size)); },
  // cam.json of the camera in use.
  camera() { return cameraToJson(viewer.currentCamera()); },
  // RGB bytes of the canvas (rows top-down) as base64.
  pixels() {
    const rgb = viewer.r.readPixels();
    let s = '';
    for (let i = 0; i < rgb.length; i += 0x8000) s += String.fromCharCode.apply(null, rgb.subarray(i, i + 0x8000));
    return { width: viewer.r.width, height: viewer.r.height, rgb: btoa(s) };
  },
  // The mesh layer of the last render: camera z per pixel (rows top-down, 0 = no mesh), base64 float32.
  meshDepth() {
    const { width: w, height: h } = viewer.r;
    const rgba = new Float32Array(4 * w * h);
    viewer.r.renderer.readRenderTargetPixels(viewer.r.meshTarget, 0, 0, w, h, rgba);
    const z = new Float32Array(w * h);
    for (let y = 0; y < h; y++) for (let x = 0; x < w; x++) z[y * w + x] = rgba[4 * ((h - 1 - y) * w + x) + 3];
    const b = new Uint8Array(z.buffer);
    let s = '';
    for (let i = 0; i < b.length; i += 0x8000) s += String.fromCharCode.apply(null, b.subarray(i, i + 0x8000));
    return btoa(s);
  },
  // Mean over n frames of repose + project/sort + render (waiting for the GPU), ms.
  benchmark(n = 20) {
    const acc = { repose: 0, project: 0, gpu: 0, total: 0 };
    const T = viewer.motion.frames.length;
    for (let i = 0; i < n; i++) {
      viewer.frame = i % T;
      const s = viewer.renderFrame();
      for (const k of Object.keys(acc)) acc[k] += s[k] / n;
    }
    return acc;
  },
};
