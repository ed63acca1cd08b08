// The third-party parts of the avatar (three.js's GLTFLoader, @pixiv/three-vrm), an entry of its
// own so that the build puts them in ../static/vendor/ beside three.js's core.
export { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
export { VRMLoaderPlugin, VRMUtils } from "@pixiv/three-vrm";
