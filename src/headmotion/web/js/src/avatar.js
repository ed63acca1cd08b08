/**
 * headmotion avatar — an ES module (three.js, its GLTFLoader and @pixiv/three-vrm bundled in; no CDN,
 * no npm at run time) that loads a VRM avatar and turns its neck and head bones.
 *
 * The default avatar is the project's own (avatar.vrm next to this module: the head model of
 * headmotion.render.mesh as a VRM 1.0 bust, written by headmotion.web.build_assets); any VRM 1.0
 * or 0.x file with neck and head bones works.  A rotation vector r (headmotion's axes: +x the
 * avatar's left, +y up, +z forward; radians; the head against the torso) is split as the BVH and
 * glTF writers split it: the neck turns by s·r and the head by (1 − s)·r, s the file's
 * asset.extras.neck_share (0.93 when the file has none).
 *
 * API
 * ---
 *   import { mountAvatar } from "/v1/avatar/static/avatar.js";
 *   const a = await mountAvatar(element, { vrmUrl: undefined,    // default: avatar.vrm beside this module
 *                                          width, height,       // default: the element's width, 4:3
 *                                          antialias,           // default: unless WebGL is drawn by the CPU
 *                                          pixelRatio });       // default: the screen's; 0.5 when WebGL is
 *                                                               // drawn by the CPU (a quarter of the pixels:
 *                                                               // drawing them competed with the stream for
 *                                                               // the cores: a median of 240 against 87 ms
 *                                                               // from the audio to the bone on 2 cores)
 *   a.setRotvec([rx, ry, rz]);     // pose the neck and head bones now (radians)
 *   a.headRotation()               // [pitch, yaw, roll] degrees: the head bone against its rest pose,
 *                                  // relative to the chest, read back from the bones (intrinsic YXZ)
 *   a.renderNow(); a.destroy();
 *   a.vrm, a.neckShare             // the loaded @pixiv/three-vrm VRM; the split in use
 */
import {
  AmbientLight, Color, DirectionalLight, HemisphereLight, PerspectiveCamera, Quaternion, Scene, Vector3,
  WebGLRenderer, Euler, SRGBColorSpace,
} from "three";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { VRMLoaderPlugin, VRMUtils } from "@pixiv/three-vrm";

const DEFAULT_NECK_SHARE = 0.93;
const DEG = 180 / Math.PI;

function rotvecQuat(r, scale, out) {
  const a = Math.hypot(r[0], r[1], r[2]) * scale;
  if (a < 1e-12) return out.identity();
  const n = new Vector3(r[0], r[1], r[2]).normalize();
  return out.setFromAxisAngle(n, a);
}

/** WebGL drawn by the CPU (SwiftShader, llvmpipe: a browser without a GPU)?  There multisampling
 * costs the page's thread tens of milliseconds a draw, which delays the audio it streams. */
function softwareGL() {
  try {
    const gl = document.createElement("canvas").getContext("webgl2") || document.createElement("canvas").getContext("webgl");
    if (!gl) return true;
    const ext = gl.getExtension("WEBGL_debug_renderer_info");
    const name = String(gl.getParameter(ext ? ext.UNMASKED_RENDERER_WEBGL : gl.RENDERER));
    const lose = gl.getExtension("WEBGL_lose_context");
    if (lose) lose.loseContext();
    return /swiftshader|llvmpipe|software/i.test(name);
  } catch (e) {
    return true;
  }
}

/** Load a VRM file and mount it in `element` (module docstring). */
export async function mountAvatar(element, options = {}) {
  const url = options.vrmUrl || new URL("./avatar.vrm", import.meta.url).href;
  const loader = new GLTFLoader();
  loader.register((parser) => new VRMLoaderPlugin(parser));
  const gltf = await loader.loadAsync(url);
  const vrm = gltf.userData.vrm;
  if (!vrm) throw new Error(`${url} is not a VRM file (no VRMC_vrm or VRM extension)`);
  const version = vrm.meta && vrm.meta.metaVersion;
  if (version === "0") VRMUtils.rotateVRM0(vrm);  // VRM 0.x faces -Z: turn it to face +Z as VRM 1.0 does
  VRMUtils.removeUnnecessaryVertices(gltf.scene);
  const extras = (gltf.parser.json.asset && gltf.parser.json.asset.extras) || {};
  const neckShare = Number.isFinite(extras.neck_share) ? extras.neck_share : DEFAULT_NECK_SHARE;
  const h = vrm.humanoid;
  const neckN = h.getNormalizedBoneNode("neck"), headN = h.getNormalizedBoneNode("head");
  const chestRaw = h.getRawBoneNode("upperChest") || h.getRawBoneNode("chest") || h.getRawBoneNode("spine");
  const headRaw = h.getRawBoneNode("head");
  if (!headN || !headRaw) throw new Error(`${url} has no head bone`);

  const scene = new Scene();
  scene.background = new Color(0xdfe3e8);
  scene.add(new HemisphereLight(0xffffff, 0x7a808a, 1.1));
  scene.add(new AmbientLight(0xffffff, 0.2));
  const key = new DirectionalLight(0xffffff, 2.6);
  key.position.set(-1.0, 2.2, 1.8);  // above and in front, from the viewer's left: the face has shape
  scene.add(key);
  const fill = new DirectionalLight(0xdde6ff, 0.6);
  fill.position.set(1.2, 1.4, 1.0);
  scene.add(fill);
  scene.add(vrm.scene);
  vrm.scene.updateMatrixWorld(true);
  const rootInv = new Quaternion();
  const worldOf = (node) => node.getWorldQuaternion(new Quaternion()).premultiply(
    vrm.scene.getWorldQuaternion(rootInv).invert());  // in the avatar's frame
  const restHead = worldOf(headRaw), restChest = chestRaw ? worldOf(chestRaw) : new Quaternion();
  const headPos = headRaw.getWorldPosition(new Vector3());

  const width = options.width || element.clientWidth || 640, height = options.height || Math.round(width * 0.75);
  const camera = new PerspectiveCamera(22, width / height, 0.05, 20);  // head and shoulders
  camera.position.set(0, headPos.y + 0.06, headPos.z + 1.3);
  camera.lookAt(0, headPos.y - 0.03, headPos.z);
  let renderer = null;
  try {
    const software = softwareGL();
    renderer = new WebGLRenderer({ antialias: options.antialias ?? !software });
    renderer.outputColorSpace = SRGBColorSpace;
    renderer.setPixelRatio(options.pixelRatio || (software ? 0.5 : window.devicePixelRatio || 1));
    renderer.setSize(width, height);
    element.appendChild(renderer.domElement);
  } catch (e) {  // no WebGL: the bones still move (tests, a page that only reads headRotation)
    renderer = null;
    element.textContent = `no WebGL: ${e && e.message || e}`;
  }

  const qn = new Quaternion(), qh = new Quaternion();
  function setRotvec(r) {
    rotvecQuat(r, neckShare, qn);
    rotvecQuat(r, neckN ? 1 - neckShare : 1, qh);
    if (neckN) neckN.quaternion.copy(qn);
    headN.quaternion.copy(qh);
    h.update();  // normalized → raw bones now, so headRotation() reads the pose just set
    vrm.scene.updateMatrixWorld(true);
  }
  function headRotation() {
    // the head's rotation since rest, less the chest's, in the avatar's axes: (chest Δ)⁻¹ (head Δ)
    const dHead = worldOf(headRaw).multiply(restHead.clone().invert());
    const dChest = chestRaw ? worldOf(chestRaw).multiply(restChest.clone().invert()) : new Quaternion();
    const q = dChest.invert().multiply(dHead);
    const e = new Euler().setFromQuaternion(q, "YXZ");  // intrinsic yaw, pitch, roll (headmotion.rotations)
    return [e.x * DEG, e.y * DEG, e.z * DEG];
  }
  let last = performance.now();
  function renderNow() {
    const now = performance.now();
    vrm.update((now - last) / 1000);
    last = now;
    if (renderer) renderer.render(scene, camera);
  }
  setRotvec([0, 0, 0]);
  renderNow();
  return {
    vrm, neckShare, scene, camera, setRotvec, headRotation, renderNow, canvas: renderer && renderer.domElement,
    destroy() { if (renderer) { renderer.dispose(); renderer.domElement.remove(); } VRMUtils.deepDispose(vrm.scene); },
  };
}

export { mountAvatar as createAvatar };
