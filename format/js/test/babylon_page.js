// Test page of the Babylon.js extension (babylon_extension_test.mjs): a plain Babylon.js
// application (UMD build, WebGL2) that imports an avatar with the glTF loader and the
// HAHA_gaussian_avatar extension, poses the skeleton's joint nodes and renders the scene.
// Draco (body mesh and Gaussians) uses the decoder served locally from three's libs/draco.
import { registerHahaGaussianAvatar } from '../babylon/HahaGaussianAvatarExtension.js';
import { glMatrices, axisAngleQuat, toBase64 } from './page_common.js';

const B = window.BABYLON;
const DRACO = '/node_modules/three/examples/jsm/libs/draco/';
B.DracoDecoder.DefaultConfiguration = {
  wasmUrl: `${location.origin}${DRACO}draco_wasm_wrapper.js`, wasmBinaryUrl: `${location.origin}${DRACO}draco_decoder.wasm`,
  fallbackUrl: `${location.origin}${DRACO}draco_decoder.js`,
};
const dracoDecoderModule = await window.DracoDecoderModule({ wasmBinary: await (await fetch(`${DRACO}draco_decoder.wasm`)).arrayBuffer() });
const extensionOptions = { dracoDecoderModule };  // read by the extension at each load
registerHahaGaussianAvatar(B, extensionOptions);

const canvas = document.getElementById('view');
const engine = new B.Engine(canvas, false, { preserveDrawingBuffer: true, antialias: false, adaptToDeviceRatio: false });
let scene = null, layer = null, camera = null, rootRest = null;

let leftHanded = false;

function newScene() {
  if (scene) scene.dispose();
  scene = new B.Scene(engine);
  scene.useRightHandedSystem = !leftHanded;
  scene.clearColor = new B.Color4(0, 0, 0, 1);
  camera = new B.Camera('opencv', B.Vector3.Zero(), scene);
  scene.activeCamera = camera;
}

window.hahaTest = {
  async load(url, options = {}) {
    leftHanded = !!options.leftHanded;  // Babylon's default handedness (the glTF mirrored by __root__)
    extensionOptions.exactBody = !!options.exactBody;
    newScene();
    const t0 = performance.now();
    await B.SceneLoader.ImportMeshAsync('', '', url, scene, undefined, '.glb');
    await scene.whenReadyAsync();
    layer = scene.metadata.hahaAvatars[0];
    rootRest = layer.joints[0].position.clone();
    const a = layer.avatar;
    return { N: a.N, V: a.V, Vg: a.Vg, version: a.version, draco: a.meshDraco, faceOrder: a.faceOrder, poseCorrectives: !!a.posedirs, loadMs: performance.now() - t0 };
  },
  setPose(pose, transl) {
    for (let j = 0; j < 55; j++) {
      const [x, y, z, w] = axisAngleQuat(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]);
      layer.joints[j].rotationQuaternion = new B.Quaternion(x, y, z, w);
    }
    layer.joints[0].position.set(rootRest.x + transl[0], rootRest.y + transl[1], rootRest.z + transl[2]);
  },
  // The same pose played by a Babylon AnimationGroup (one key per joint node) instead of set by hand.
  setPoseByMixer(pose, transl) {
    const group = new B.AnimationGroup('pose', scene);
    for (let j = 0; j < 55; j++) {
      const [x, y, z, w] = axisAngleQuat(pose[3 * j], pose[3 * j + 1], pose[3 * j + 2]);
      const anim = new B.Animation(`q${j}`, 'rotationQuaternion', 30, B.Animation.ANIMATIONTYPE_QUATERNION);
      anim.setKeys([{ frame: 0, value: new B.Quaternion(x, y, z, w) }, { frame: 1, value: new B.Quaternion(x, y, z, w) }]);
      group.addTargetedAnimation(anim, layer.joints[j]);
    }
    const anim = new B.Animation('root', 'position', 30, B.Animation.ANIMATIONTYPE_VECTOR3);
    const p = new B.Vector3(rootRest.x + transl[0], rootRest.y + transl[1], rootRest.z + transl[2]);
    anim.setKeys([{ frame: 0, value: p }, { frame: 1, value: p.clone() }]);
    group.addTargetedAnimation(anim, layer.joints[0]);
    group.start(false, 1, 0, 1);
    group.goToFrame(1);
    group.pause();
    return group.targetedAnimations.length;
  },
  render(cam, gaussians = true) {
    layer.mesh.setEnabled(gaussians);
    engine.setSize(cam.width, cam.height);
    const { view, proj } = glMatrices(cam, leftHanded);
    const V = B.Matrix.FromArray(view), P = B.Matrix.FromArray(proj);
    camera.getViewMatrix = () => V;
    camera.freezeProjectionMatrix(P);
    camera.minZ = cam.near ?? 0.01;
    const t0 = performance.now();
    scene.render();
    const gl = engine._gl;
    const rgba = new Uint8Array(4 * cam.width * cam.height);
    gl.readPixels(0, 0, cam.width, cam.height, gl.RGBA, gl.UNSIGNED_BYTE, rgba);
    const ms = performance.now() - t0;
    const rgb = new Uint8Array(3 * cam.width * cam.height);
    for (let y = 0; y < cam.height; y++) for (let x = 0; x < cam.width; x++) for (let c = 0; c < 3; c++) {
      rgb[3 * (y * cam.width + x) + c] = rgba[4 * ((cam.height - 1 - y) * cam.width + x) + c];
    }
    return { rgb: toBase64(rgb), ms, visible: layer.visibleSplats };
  },
  // World Gaussian centres and the centroids of their faces as Babylon skins the body
  // (Mesh.getPositionData with the skeleton applied), base64 float64.
  centres() {
    scene.render();  // skeleton and layer up to date
    const a = layer.avatar, means = layer.worldMeans();
    const body = layer.bodyNode;
    const pos = body.getPositionData(true, true);
    const world = body.getWorldMatrix();
    const gOf = new Int32Array(a.V).fill(-1);
    for (let g = 0; g < a.Vg; g++) if (gOf[a.bodyVertex[g]] < 0) gOf[a.bodyVertex[g]] = g;
    const cen = new Float64Array(3 * a.N);
    for (let i = 0; i < a.N; i++) {
      const f = a.gFace[i];
      for (let k = 0; k < 3; k++) {
        const g = gOf[a.faces[3 * f + k]];
        const p = B.Vector3.TransformCoordinates(new B.Vector3(pos[3 * g], pos[3 * g + 1], pos[3 * g + 2]), world);
        cen[3 * i] += p.x / 3; cen[3 * i + 1] += p.y / 3; cen[3 * i + 2] += p.z / 3;
      }
    }
    return { means: toBase64(new Uint8Array(means.buffer)), centroids: toBase64(new Uint8Array(cen.buffer)) };
  },
};
window.hahaReady = true;
