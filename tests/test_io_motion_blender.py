"""Our BVH export imported by Blender itself (exports animators can import).

Blender (Debian's ``blender`` package, run headless) imports the files with
``bpy.ops.import_anim.bvh`` and reports the Head bone's rotation relative to the Spine bone, in
world space, at a few frames (and the Neck bone's, which must hold ``neck_share`` of the
rotation: the default share, 0.5 and 0); we map Blender's Z-up axes back (the importer's default
``axis_forward='-Z', axis_up='Y'`` sends BVH (x, y, z) to Blender (x, −z, y)) and compare with the
motion we wrote, within 0.1°.  Skipped when ``blender`` is not installed.
"""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.io.bvh import DEFAULT_NECK_SHARE
from headmotion.io.motion import save_motion
from headmotion.types import Motion

BLENDER = shutil.which("blender")

SCRIPT = r'''
import builtins, json, sys
import bpy

_open = builtins.open
def _open_no_u(file, mode="r", *a, **k):  # Debian's Blender 3.4 importer opens with 'rU' (gone in Python 3.11)
    return _open(file, mode.replace("U", ""), *a, **k)
builtins.open = _open_no_u

argv = sys.argv[sys.argv.index("--") + 1:]
out, frames, files = argv[0], [int(x) for x in argv[1].split(",")], argv[2:]
result = {}
for path in files:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=path, update_scene_fps=True, update_scene_duration=True)
    obj = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"][0]
    scene = bpy.context.scene
    res = {"fps": scene.render.fps / scene.render.fps_base, "bones": [b.name for b in obj.pose.bones], "frames": {}}
    for f in frames:
        scene.frame_set(scene.frame_start + f)
        d = {}
        for name in ("Spine", "Neck", "Head"):
            pb = obj.pose.bones[name]
            cur = (obj.matrix_world @ pb.matrix).to_3x3()
            rest = (obj.matrix_world @ pb.bone.matrix_local).to_3x3()
            d[name] = cur @ rest.inverted()
        rel = d["Spine"].inverted() @ d["Head"]
        neck = d["Spine"].inverted() @ d["Neck"]
        res["frames"][str(f)] = [list(r) for r in rel]
        res.setdefault("neck", {})[str(f)] = [list(r) for r in neck]
    result[path] = res
json.dump(result, _open(out, "w"))
'''

# Blender world (Z-up) = G @ BVH (Y-up)
G = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])


@pytest.mark.slow
@pytest.mark.skipif(BLENDER is None, reason="blender is not installed (apt-get install blender)")
def test_blender_imports_our_bvh(tmp_path):
    fps = 30.0
    t = np.arange(90) / fps
    rv = np.stack([0.4 * np.sin(2 * np.pi * t), 0.6 * np.sin(np.pi * t + 1), 0.3 * np.cos(1.4 * np.pi * t)], 1)
    m = Motion(rv.copy(), fps)  # (Motion makes the array it is given read-only)
    files = {}
    shares = {"zxy": DEFAULT_NECK_SHARE, "yxz": DEFAULT_NECK_SHARE, "neck": 0.5, "head_only": 0.0}
    for name, kw in (("zxy", {}), ("yxz", {"channel_order": "YXZ"}), ("neck", {"neck_share": 0.5}),
                     ("head_only", {"neck_share": 0.0})):
        files[name] = tmp_path / f"{name}.bvh"
        save_motion(m, files[name], **kw)
    script = tmp_path / "check.py"
    script.write_text(SCRIPT)
    out = tmp_path / "out.json"
    frames = [0, 10, 37, 89]
    proc = subprocess.run(
        [BLENDER, "-b", "--factory-startup", "--python", str(script), "--", str(out), ",".join(map(str, frames)),
         *map(str, files.values())],
        capture_output=True, text=True, timeout=300)
    if not out.exists():
        pytest.fail(f"blender failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")
    res = json.loads(out.read_text())
    for name, path in files.items():
        r = res[str(path)]
        assert r["fps"] == pytest.approx(fps)
        assert r["bones"][:4] == ["Hips", "Spine", "Neck", "Head"]
        for f in frames:
            rel = G.T @ np.array(r["frames"][str(f)]) @ G
            err = (Rotation.from_matrix(rel).inv() * Rotation.from_rotvec(rv[f])).magnitude()
            assert np.degrees(err) < 0.1, (name, f, np.degrees(err))
            # the neck bone holds its share of the rotation (the rig bends at the neck too)
            neck = G.T @ np.array(r["neck"][str(f)]) @ G
            err = (Rotation.from_matrix(neck).inv() * Rotation.from_rotvec(shares[name] * rv[f])).magnitude()
            assert np.degrees(err) < 0.1, (name, "neck", f, np.degrees(err))
