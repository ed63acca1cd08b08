// The parts of three.js the glTF browser test needs (tests/test_io_gltf.py), bundled by build.mjs
// into three_gltf.js so the test runs offline (three.js: MIT licence, https://threejs.org).
export {
  AnimationMixer, Scene, PerspectiveCamera, WebGLRenderer, HemisphereLight, DirectionalLight,
  Quaternion, Color,
} from "three";
export { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";
