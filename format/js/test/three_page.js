// Test page of the three.js plugin (three_plugin_test.mjs; page.html?engine=three): a plain
// three.js application that loads an avatar with GLTFLoader + HahaGaussianAvatarPlugin, poses
// the skeleton's bones and renders with an ordinary WebGLRenderer.render(scene, camera).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/addons/loaders/DRACOLoader.js';
import { HahaGaussianAvatarPlugin } from '../three/HahaGaussianAvatarPlugin.js';
import {
  threeApp, poseBones, applyOpenCvCamera, jointQuats, rootPosition, avatarInfo, renderAndRead, faceCentroids, centresBase64,
} from './page_common.js';

const { renderer, scene, camera, draco } = threeApp(THREE, DRACOLoader);
let gltf = null, layer = null, skinned = null, rootRest = null;
const rest = () => rootRest || (rootRest = skinned.skeleton.bones[0].position.clone());

export default {
  async load(url, options = {}) {
    if (gltf) scene.remove(gltf.scene);
    rootRest = null;
    const loader = new GLTFLoader().setDRACOLoader(draco);
    loader.register((parser) => new HahaGaussianAvatarPlugin(parser, { dracoLoader: draco, name: url, ...options }));
    const t0 = performance.now();
    gltf = await loader.loadAsync(url);
    layer = gltf.userData.hahaAvatar;
    skinned = layer.skinnedMesh;
    scene.add(gltf.scene);
    return avatarInfo(layer.avatar, t0);
  },
  // SMPL-X pose (165 axis-angle values) and translation, set on the bones as an application would.
  setPose(pose, transl) { poseBones(THREE, skinned.skeleton.bones, pose, transl, rest()); },
  // The same pose played by a three.js AnimationMixer (one keyframe per bone: quaternion, and
  // the root's position) instead of set by hand.
  setPoseByMixer(pose, transl) {
    const bones = skinned.skeleton.bones;
    const tracks = jointQuats(pose).map((q, j) => new THREE.QuaternionKeyframeTrack(`${bones[j].name}.quaternion`, [0], q));
    tracks.push(new THREE.VectorKeyframeTrack(`${bones[0].name}.position`, [0], rootPosition(rest(), transl)));
    const mixer = new THREE.AnimationMixer(gltf.scene);
    mixer.clipAction(new THREE.AnimationClip('pose', 1, tracks)).play();
    mixer.update(0);
    return tracks.length;
  },
  // The file's own animation (gltf.animations[index], made by GLTFLoader) played by an
  // AnimationMixer at `seconds`, from the rest pose.
  playAnimation(index, seconds) {
    poseBones(THREE, skinned.skeleton.bones, new Array(165).fill(0), [0, 0, 0], rest());
    const clip = gltf.animations[index];
    const mixer = new THREE.AnimationMixer(gltf.scene);
    mixer.clipAction(clip).play();
    mixer.setTime(seconds);
    return { name: clip.name, duration: clip.duration, tracks: clip.tracks.length };
  },
  render(cam, gaussians = true) {
    layer.visible = gaussians;
    renderer.setSize(cam.width, cam.height, false);
    applyOpenCvCamera(cam, camera);
    const shot = renderAndRead(renderer.getContext(), cam, () => renderer.render(scene, camera));
    return { ...shot, visible: layer.visibleSplats };
  },
  // World Gaussian centres of the layer, and the centroids of their faces as three.js skins
  // the body (SkinnedMesh.getVertexPosition: its GPU skinning maths on the CPU), base64 float64.
  centres() {
    gltf.scene.updateMatrixWorld(true);
    const means = layer.worldMeans(), v = new THREE.Vector3();
    // One SkinnedMesh per primitive of the body mesh (the body's, then a garment's): glTF
    // vertex g of the avatar is vertex g - first of the part it falls in.
    const parts = layer.bodyParts;
    const centroids = faceCentroids(layer.avatar, (g) => {
      let k = 0;
      while (g >= parts[k].geometry.attributes.position.count) g -= parts[k++].geometry.attributes.position.count;
      parts[k].getVertexPosition(g, v);
      v.applyMatrix4(parts[k].matrixWorld);
      return [v.x, v.y, v.z];
    });
    return centresBase64(means, centroids);
  },
  benchmark(cam, n = 10) {
    const t0 = performance.now();
    for (let i = 0; i < n; i++) { skinned.skeleton.bones[18].rotation.z += 0.01; this.render(cam); }
    return (performance.now() - t0) / n;
  },
};
