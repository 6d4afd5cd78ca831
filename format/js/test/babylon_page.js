// Test page of the Babylon.js extension (babylon_extension_test.mjs; page.html?engine=babylon):
// a plain Babylon.js application (UMD build, WebGL2) that imports an avatar with the glTF
// loader and the HAHA_gaussian_avatar extension, poses the skeleton's joint nodes and renders
// the scene. Draco (body mesh and Gaussians) uses the decoder served locally from three's libs/draco.
import { registerHahaGaussianAvatar } from '../babylon/HahaGaussianAvatarExtension.js';
import {
  DRACO_PATH as DRACO, glMatrices, jointQuats, rootPosition, avatarInfo, renderAndRead, faceCentroids, centresBase64,
} from './page_common.js';

const B = window.BABYLON;
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

export default {
  async load(url, options = {}) {
    leftHanded = !!options.leftHanded;  // Babylon's default handedness (the glTF mirrored by __root__)
    extensionOptions.exactBody = !!options.exactBody;
    newScene();
    const t0 = performance.now();
    await B.SceneLoader.ImportMeshAsync('', '', url, scene, undefined, '.glb');
    await scene.whenReadyAsync();
    layer = scene.metadata.hahaAvatars[0];
    rootRest = layer.joints[0].position.clone();
    return avatarInfo(layer.avatar, t0);
  },
  setPose(pose, transl) {
    jointQuats(pose).forEach(([x, y, z, w], j) => { layer.joints[j].rotationQuaternion = new B.Quaternion(x, y, z, w); });
    layer.joints[0].position.set(...rootPosition(rootRest, transl));
  },
  // The same pose played by a Babylon AnimationGroup (one key per joint node) instead of set by hand.
  setPoseByMixer(pose, transl) {
    const group = new B.AnimationGroup('pose', scene);
    jointQuats(pose).forEach(([x, y, z, w], j) => {
      const anim = new B.Animation(`q${j}`, 'rotationQuaternion', 30, B.Animation.ANIMATIONTYPE_QUATERNION);
      anim.setKeys([{ frame: 0, value: new B.Quaternion(x, y, z, w) }, { frame: 1, value: new B.Quaternion(x, y, z, w) }]);
      group.addTargetedAnimation(anim, layer.joints[j]);
    });
    const anim = new B.Animation('root', 'position', 30, B.Animation.ANIMATIONTYPE_VECTOR3);
    const p = new B.Vector3(...rootPosition(rootRest, transl));
    anim.setKeys([{ frame: 0, value: p }, { frame: 1, value: p.clone() }]);
    group.addTargetedAnimation(anim, layer.joints[0]);
    group.start(false, 1, 0, 1);
    group.goToFrame(1);
    group.pause();
    return group.targetedAnimations.length;
  },
  // The file's own animation (scene.animationGroups[index], made by the glTF loader) moved
  // with AnimationGroup.goToFrame to `seconds` (its frames are the loader's, not the file's).
  playAnimation(index, seconds) {
    this.setPose(new Array(165).fill(0), [0, 0, 0]);
    for (const g of scene.animationGroups) g.stop();
    const group = scene.animationGroups[index];
    const fps = group.targetedAnimations[0].animation.framePerSecond;
    group.start(false, 1, group.from, group.to);
    group.pause();
    group.goToFrame(seconds * fps);
    return { name: group.name, duration: (group.to - group.from) / fps, tracks: group.targetedAnimations.length };
  },
  render(cam, gaussians = true) {
    layer.mesh.setEnabled(gaussians);
    engine.setSize(cam.width, cam.height);
    const { view, proj } = glMatrices(cam, leftHanded);
    const V = B.Matrix.FromArray(view), P = B.Matrix.FromArray(proj);
    camera.getViewMatrix = () => V;
    camera.freezeProjectionMatrix(P);
    camera.minZ = cam.near ?? 0.01;
    const shot = renderAndRead(engine._gl, cam, () => scene.render());
    return { ...shot, visible: layer.visibleSplats };
  },
  // World Gaussian centres and the centroids of their faces as Babylon skins the body
  // (Mesh.getPositionData with the skeleton applied), base64 float64.
  centres() {
    scene.render();  // skeleton and layer up to date
    const means = layer.worldMeans();
    // One mesh per primitive of the body mesh (the body's, then a garment's): glTF vertex g of
    // the avatar is vertex g - first of the part it falls in.
    const parts = layer.bodyParts.map((m) => ({ pos: m.getPositionData(true, true), world: m.getWorldMatrix() }));
    const centroids = faceCentroids(layer.avatar, (g) => {
      let k = 0;
      while (g >= parts[k].pos.length / 3) g -= parts[k++].pos.length / 3;
      const { pos, world } = parts[k];
      const p = B.Vector3.TransformCoordinates(new B.Vector3(pos[3 * g], pos[3 * g + 1], pos[3 * g + 2]), world);
      return [p.x, p.y, p.z];
    });
    return centresBase64(means, centroids);
  },
};
