"""glTF 2.0 export: the keyframes decode to the motion; three.js's GLTFLoader
loads and plays the file in headless Chromium; Blender's glTF importer reports the same head
rotation.

The browser test uses three.js bundled offline in ``tests/web_gltf/three_gltf.js`` (built by
``tests/web_gltf/build.mjs``; no CDN).  Browser and Blender tests skip when chromium / Playwright /
blender are missing.
"""

from __future__ import annotations

import base64
import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp

from headmotion.errors import FormatError, ParameterError
from headmotion.io.bvh import DEFAULT_NECK_SHARE
from headmotion.io.gltf import load_gltf, save_gltf
from headmotion.io.motion import save_motion
from headmotion.types import Motion

pygltflib = pytest.importorskip("pygltflib")

HERE = Path(__file__).resolve().parent
FPS = 30.0


def _motion(n=90, fps=FPS):
    t = np.arange(n) / fps
    rv = np.stack([0.4 * np.sin(2 * np.pi * t), 0.6 * np.sin(np.pi * t + 1), 0.3 * np.cos(1.4 * np.pi * t)], 1)
    return Motion(rv, fps)


def _decode(path):
    """Independent decoding with pygltflib: node names, parents, times and quaternion tracks."""
    doc = pygltflib.GLTF2().load(str(path))
    if str(path).endswith(".gltf"):
        blob = base64.b64decode(doc.buffers[0].uri.split(",", 1)[1])
    else:
        blob = doc.binary_blob()

    def arr(i):
        a = doc.accessors[i]
        v = doc.bufferViews[a.bufferView]
        n = {"SCALAR": 1, "VEC4": 4}[a.type]
        assert a.componentType == 5126  # float32
        x = np.frombuffer(blob, np.float32, a.count * n, (v.byteOffset or 0) + (a.byteOffset or 0))
        return x.reshape(a.count, n) if n > 1 else x

    names = [n.name for n in doc.nodes]
    parent = {c: names[k] for k, n in enumerate(doc.nodes) for c in (n.children or [])}
    anim = doc.animations[0]
    tracks = {}
    for ch in anim.channels:
        s = anim.samplers[ch.sampler]
        assert s.interpolation == "LINEAR"
        tracks[(names[ch.target.node], ch.target.path)] = (arr(s.input), arr(s.output))
    return doc, names, {names[c]: p for c, p in parent.items()}, tracks


@pytest.mark.parametrize("ext", ["glb", "gltf"])
@pytest.mark.parametrize("share", [None, 0.0, 0.5])
def test_keyframes_decode_to_the_motion(tmp_path, ext, share):
    m = _motion()
    p = tmp_path / f"m.{ext}"
    save_motion(m, p, **({} if share is None else {"neck_share": share}))
    s = DEFAULT_NECK_SHARE if share is None else share
    doc, names, parent, tracks = _decode(p)
    assert doc.asset.version == "2.0"
    # VRM humanoid bone names in a chain
    assert [parent.get(n) for n in ("spine", "chest", "neck", "head")] == ["hips", "spine", "chest", "neck"]
    assert set(tracks) == {("neck", "rotation"), ("head", "rotation")}
    t_n, q_n = tracks[("neck", "rotation")]
    t_h, q_h = tracks[("head", "rotation")]
    np.testing.assert_allclose(t_n, np.arange(len(m)) / FPS, atol=1e-6)
    np.testing.assert_array_equal(t_n, t_h)
    # glTF quaternions are (x, y, z, w) = scipy's order; the axes are ours (identity mapping)
    neck, head = Rotation.from_quat(q_n.astype(float)), Rotation.from_quat(q_h.astype(float))
    target = Rotation.from_rotvec(np.array(m.rotvec))
    assert np.max(((neck * head).inv() * target).magnitude()) < 1e-6
    assert np.max((neck.inv() * Rotation.from_rotvec(s * np.array(m.rotvec))).magnitude()) < 1e-6
    # consecutive keyframes in the same hemisphere (LINEAR = slerp takes the short way)
    assert np.all(np.sum(q_h[1:] * q_h[:-1], axis=1) > 0) and np.all(np.sum(q_n[1:] * q_n[:-1], axis=1) > 0)
    r = load_gltf(p)
    assert r.fps == FPS and np.max(np.abs(r.rotvec - m.rotvec)) < 1e-6


def test_gltf_axis_convention_nod_down_is_positive_x(tmp_path):
    """+0.3 rad pitch (nose down in our convention) rotates the head's forward axis +Z towards
    −Y in glTF's frame, which is +Y up, +Z forward."""
    m = Motion(np.tile([0.3, 0.0, 0.0], (3, 1)), FPS)
    p = tmp_path / "nod.glb"
    save_gltf(m, p, neck_share=0.0)
    _, _, _, tracks = _decode(p)
    fwd = Rotation.from_quat(tracks[("head", "rotation")][1][0].astype(float)).apply([0, 0, 1])
    np.testing.assert_allclose(fwd, [0, -np.sin(0.3), np.cos(0.3)], atol=1e-6)


def test_bad_input(tmp_path):
    with pytest.raises(FormatError, match=r"\.glb or \.gltf"):
        save_gltf(_motion(), tmp_path / "a.fbx")
    with pytest.raises(ParameterError, match="neck_share"):
        save_motion(_motion(), tmp_path / "a.glb", neck_share=1.5)
    with pytest.raises(ParameterError, match="zero frames"):
        save_gltf(Motion(np.zeros((0, 3)), FPS), tmp_path / "a.glb")
    assert not (tmp_path / "a.glb").exists()


# ---------------------------------------------------------------------------------- three.js
CHROMIUM = os.environ.get("HEADMOTION_CHROMIUM", "/usr/bin/chromium")
ORIGIN = "http://headmotion.test"

PAGE = """<!doctype html><html><body style="margin:0;background:#000">
<canvas id="c" width="320" height="320"></canvas>
<script type="module">
import * as T from "./three_gltf.js";
window.check = async (times) => {
  const buf = await (await fetch("./m.glb")).arrayBuffer();
  const gltf = await new Promise((ok, bad) => new T.GLTFLoader().parse(buf, "", ok, bad));
  const scene = new T.Scene();
  scene.background = new T.Color(0x000000);
  scene.add(gltf.scene, new T.HemisphereLight(0xffffff, 0x444444, 3.0));
  const camera = new T.PerspectiveCamera(30, 1, 0.05, 20);
  camera.position.set(0.0, 1.65, 1.4);     // in front of the face (+Z), looking back at it
  camera.lookAt(0, 1.65, 0);
  const renderer = new T.WebGLRenderer({canvas: document.getElementById("c"), preserveDrawingBuffer: true});
  const mixer = new T.AnimationMixer(gltf.scene);
  const clip = gltf.animations[0];
  mixer.clipAction(clip).play();
  const chest = gltf.scene.getObjectByName("chest"), head = gltf.scene.getObjectByName("head");
  const out = {names: [], clip: clip.name, duration: clip.duration, tracks: clip.tracks.map(t => t.name),
               skinned: 0, q: [], images: []};
  gltf.scene.traverse(o => { out.names.push(o.name); if (o.isSkinnedMesh) out.skinned += 1; });
  for (const t of times) {
    mixer.setTime(t);
    gltf.scene.updateMatrixWorld(true);
    const qc = new T.Quaternion(), qh = new T.Quaternion();
    chest.getWorldQuaternion(qc); head.getWorldQuaternion(qh);
    const rel = qc.invert().multiply(qh);
    out.q.push([rel.x, rel.y, rel.z, rel.w]);
    renderer.render(scene, camera);
    out.images.push(renderer.domElement.toDataURL("image/png"));
  }
  return out;
};
window.ready = true;
</script></body></html>"""


@pytest.fixture(scope="module")
def browser():
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright (Python) is not installed")
    if not Path(CHROMIUM).exists():
        pytest.skip(f"chromium not installed at {CHROMIUM} (apt-get install chromium)")
    with sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, headless=True,
                               args=["--no-sandbox", "--disable-gpu", "--use-gl=swiftshader",
                                     "--enable-unsafe-swiftshader"])
        yield b
        b.close()


@pytest.mark.slow
def test_threejs_gltfloader_loads_and_plays(tmp_path, browser):
    from PIL import Image
    import io

    m = _motion()
    glb = tmp_path / "m.glb"
    save_gltf(m, glb)
    files = {"/index.html": (PAGE.encode(), "text/html"),
             "/three_gltf.js": ((HERE / "web_gltf" / "three_gltf.js").read_bytes(), "text/javascript"),
             "/m.glb": (glb.read_bytes(), "model/gltf-binary")}
    page = browser.new_page()
    errors = []
    page.on("pageerror", lambda e: errors.append(str(e)))

    def serve(route):
        path = route.request.url[len(ORIGIN):].split("?")[0]
        if path in files:
            body, ctype = files[path]
            route.fulfill(status=200, body=body, headers={"Content-Type": ctype})
        else:
            route.fulfill(status=404, body=b"")

    page.route(f"{ORIGIN}/**", serve)
    page.goto(f"{ORIGIN}/index.html")
    page.wait_for_function("window.ready === true", timeout=30000)
    # keyframe times, and times between keyframes (three.js slerps)
    times = [0.0, 10 / FPS, 37 / FPS, 37.5 / FPS, 61.25 / FPS]
    out = page.evaluate("times => window.check(times)", times)
    assert not errors, errors
    assert out["clip"] == "headmotion" and out["duration"] == pytest.approx((len(m) - 1) / FPS, abs=1e-5)
    assert sorted(out["tracks"]) == ["head.quaternion", "neck.quaternion"]
    assert {"hips", "spine", "chest", "neck", "head"} <= set(out["names"]) and out["skinned"] == 1
    slerp = Slerp(m.times, Rotation.from_rotvec(np.array(m.rotvec)))
    for t, q in zip(times, out["q"]):
        err = (Rotation.from_quat(q).inv() * slerp([t])[0]).magnitude()
        assert np.degrees(err) < 0.05, (t, np.degrees(err))
    # it plays: the body is drawn, and the picture changes as the head moves
    imgs = [np.asarray(Image.open(io.BytesIO(base64.b64decode(u.split(",", 1)[1]))).convert("L"), float)
            for u in out["images"]]
    assert (imgs[0] > 20).mean() > 0.05, "nothing drawn"
    assert np.abs(imgs[0] - imgs[2]).mean() > 1.0, "the head did not move"
    Image.fromarray(np.hstack(imgs).astype(np.uint8)).save(tmp_path / "frames.png")


# ---------------------------------------------------------------------------------- Blender
BLENDER = shutil.which("blender")

BLENDER_SCRIPT = r'''
import json, sys
import bpy

argv = sys.argv[sys.argv.index("--") + 1:]
out, path, fps, frames = argv[0], argv[1], float(argv[2]), [int(x) for x in argv[3].split(",")]
try:
    import numpy  # the glTF importer needs it; Debian's Blender runs the system Python without it
except ImportError:
    sys.path.append(argv[4])  # the test's own site-packages (same Python minor version)
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.context.scene.render.fps = int(round(fps))
bpy.context.scene.render.fps_base = 1.0
bpy.ops.import_scene.gltf(filepath=path)
arm = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"][0]
res = {"bones": [b.name for b in arm.pose.bones], "actions": [a.name for a in bpy.data.actions], "frames": {}}
for f in frames:
    bpy.context.scene.frame_set(f)   # Blender 3.4 puts t = i / fps at frame i (scene fps set first)
    d = {}
    for name in ("chest", "head"):
        pb = arm.pose.bones[name]
        cur = (arm.matrix_world @ pb.matrix).to_3x3()
        rest = (arm.matrix_world @ pb.bone.matrix_local).to_3x3()
        d[name] = cur @ rest.inverted()
    rel = d["chest"].inverted() @ d["head"]
    res["frames"][str(f)] = [list(r) for r in rel]
json.dump(res, open(out, "w"))
'''

# Blender world (Z-up) = G @ glTF (Y-up): the importer sends glTF (x, y, z) to Blender (x, -z, y)
G = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])


@pytest.mark.slow
@pytest.mark.skipif(BLENDER is None, reason="blender is not installed (apt-get install blender)")
def test_blender_imports_our_glb(tmp_path):
    m = _motion()
    glb = tmp_path / "m.glb"
    save_gltf(m, glb)
    script = tmp_path / "check.py"
    script.write_text(BLENDER_SCRIPT)
    out = tmp_path / "out.json"
    frames = [0, 10, 37, 89]
    site = str(Path(np.__file__).resolve().parents[1])
    proc = subprocess.run([BLENDER, "-b", "--factory-startup", "--python", str(script), "--", str(out), str(glb),
                           str(FPS), ",".join(map(str, frames)), site], capture_output=True, text=True, timeout=300)
    if not out.exists():
        pytest.fail(f"blender failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
    res = json.loads(out.read_text())
    assert {"hips", "spine", "chest", "neck", "head"} <= set(res["bones"])
    assert any("headmotion" in a for a in res["actions"])
    for f in frames:
        rel = G.T @ np.array(res["frames"][str(f)]) @ G
        err = (Rotation.from_matrix(rel).inv() * Rotation.from_rotvec(np.array(m.rotvec[f]))).magnitude()
        assert np.degrees(err) < 0.1, (f, np.degrees(err))


def test_cli_convert_real_bvh_to_glb(tmp_path, shared_data):
    """``headmotion convert take.bvh out.glb``: the ZEGGS take as a glTF animation."""
    from headmotion.cli import main
    from headmotion.io.motion import load_motion

    src = shared_data / "mocap_speech" / "zeggs" / "067_Speech_2_x_1_0.bvh"
    dst = tmp_path / "zeggs.glb"
    assert main(["convert", str(src), str(dst)]) == 0
    m, r = load_motion(src), load_gltf(dst)
    assert r.fps == m.fps and len(r) == len(m) == 2065
    err = (Rotation.from_rotvec(np.array(r.rotvec)).inv() * Rotation.from_rotvec(np.array(m.rotvec))).magnitude()
    assert np.max(err) < 1e-6
