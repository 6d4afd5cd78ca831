// Test page of the three.js plugin (three_plugin_test.mjs): a plain three.js application
// that loads an avatar with GLTFLoader + HahaGaussianAvatarPlugin, poses the skeleton's bones
// and renders with an ordinary WebGLRenderer.render(scene, camera).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { HahaGaussianAvatarPlugin } from '../three/HahaGaussianAvatarPlugin.js';
import { poseBones, applyOpenCvCamera, axisAngleQuat, toBase64 } from './page_common.js';

const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0, 0, 0);
const camera = new THREE.PerspectiveCamera();
const draco = new DRACOLoader().setDecoderPath('/node_modules/three/examples/jsm/libs/draco/');
let gltf = null, layer = null, skinned = null;

window.hahaTest = {
  async load(url, options = {}) {
    if (gltf) scene.remove(gltf.scene);
    this._rootRest = null;
    const loader = new GLTFLoader().setDRACOLoader(draco);
    loader.register((parser) => new HahaGaussianAvatarPlugin(parser, { dracoLoader: draco, name: url, ...options }));
    const t0 = performance.now();
    gltf = await loader.loadAsync(url);
    layer = gltf.userData.hahaAvatar;
    skinned = layer.skinnedMesh;
    scene.add(gltf.scene);
    const a = layer.avatar;
    return { N: a.N, V: a.V, Vg: a.Vg, version: a.version, draco: a.meshDraco, faceOrder: a.faceOrder, poseCorrectives: !!a.posedirs, loadMs: performance.now() - t0 };
  },
  // SMPL-X pose (165 axis-angle values) and translation, set on the bones as an application would.
  setPose(pose, transl) { poseBones(THREE, skinned.skeleton.bones, pose, transl, this._rootRest || (this._rootRest = skinned.skeleton.bones[0].position.clone())); },
  // The same pose played by a three.js AnimationMixer (one keyframe per bone: quaternion, and
  // the root's position) instead of set by hand.
  setPoseByMixer(pose, transl) {
    const bones = skinned.skeleton.bones, rest = this._rootRest || (this._rootRest = bones[0].position.clone());
    const tracks = [];
    for (let j = 0; j < 55; j++) {
      const [x, y, z, w] = axisAngleQuat(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]);
      tracks.push(new THREE.QuaternionKeyframeTrack(`${bones[j].name}.quaternion`, [0], [x, y, z, w]));
    }
    tracks.push(new THREE.VectorKeyframeTrack(`${bones[0].name}.position`, [0], [rest.x + transl[0], rest.y + transl[1], rest.z + transl[2]]));
    const mixer = new THREE.AnimationMixer(gltf.scene);
    mixer.clipAction(new THREE.AnimationClip('pose', 1, tracks)).play();
    mixer.update(0);
    return tracks.length;
  },
  render(cam, gaussians = true) {
    layer.visible = gaussians;
    renderer.setSize(cam.width, cam.height, false);
    applyOpenCvCamera(cam, camera);
    const t0 = performance.now();
    renderer.render(scene, camera);
    const gl = renderer.getContext();
    const rgba = new Uint8Array(4 * cam.width * cam.height);
    gl.readPixels(0, 0, cam.width, cam.height, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
    const ms = performance.now() - t0;
    const rgb = new Uint8Array(3 * cam.width * cam.height);
    for (let y = 0; y < cam.height; y++) for (let x = 0; x < cam.width; x++) for (let c = 0; c < 3; c++) {
      rgb[3 * (y * cam.width + x) + c] = rgba[4 * ((cam.height - 1 - y) * cam.width + x) + c];
    }
    return { rgb: toBase64(rgb), ms, visible: layer.visibleSplats };
  },
  // World Gaussian centres of the layer, and the centroids of their faces as three.js skins
  // the body (SkinnedMesh.getVertexPosition: its GPU skinning maths on the CPU), base64 float64.
  centres() {
    gltf.scene.updateMatrixWorld(true);
    const a = layer.avatar, means = layer.worldMeans();
    const gOf = new Int32Array(a.V).fill(-1);
    for (let g = 0; g < a.Vg; g++) if (gOf[a.bodyVertex[g]] < 0) gOf[a.bodyVertex[g]] = g;
    const v = new THREE.Vector3(), cen = new Float64Array(3 * a.N), cache = new Map();
    const skinnedPos = (b) => {
      if (!cache.has(b)) { skinned.getVertexPosition(gOf[b], v); v.applyMatrix4(skinned.matrixWorld); cache.set(b, [v.x, v.y, v.z]); }
      return cache.get(b);
    };
    for (let i = 0; i < a.N; i++) {
      const f = a.gFace[i];
      for (let k = 0; k < 3; k++) {
        const p = skinnedPos(a.faces[3 * f + k]);
        for (let c = 0; c < 3; c++) cen[3 * i + c] += p[c] / 3;
      }
    }
    return { means: toBase64(new Uint8Array(means.buffer)), centroids: toBase64(new Uint8Array(cen.buffer)) };
  },
  benchmark(cam, n = 10) {
    const t0 = performance.now();
    for (let i = 0; i < n; i++) { skinned.skeleton.bones[18].rotation.z += 0.01; this.render(cam); }
    return (performance.now() - t0) / n;
  },
};
window.hahaReady = true;
