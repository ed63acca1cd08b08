"""The Blender add-on (``headmotion blender-addon``) in Debian's Blender, headless.

tests/blender_addon_check.py installs the zip, keys rigs whose neck and head bones have unusual
rest orientations and rolls (VRoid names with quaternions, UE names with Euler and axis-angle
modes and an unkeyed bone between neck and head, Mixamo names fed from a sound strip at 29.97
frames a second) and measures each frame's head rotation against rest in the space of the neck's
parent.  Mapped back to headmotion's axes (Blender x, y, z = our x, -z, y for a character facing
-Y, +Z up) it must equal the motion ``headmotion synth`` makes with the same options within 1°, and
the neck must hold its share.  Skipped when ``blender`` is not installed."""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import headmotion
from headmotion.blender import ADDON_NAME, addon_source, write_addon
from headmotion.cli import main
from headmotion.synthesis import synthesize

BLENDER = shutil.which("blender")
CHECK = Path(__file__).resolve().parent / "blender_addon_check.py"
SPEECH = Path(__file__).resolve().parents[1] / "examples" / "speech" / "speech_female.wav"
# headmotion axes -> Blender armature axes (columns: where x, y, z go)
M = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])


def _bones_module():
    spec = importlib.util.spec_from_file_location("hm_bones", addon_source() / "bones.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_zip_holds_one_folder_with_the_add_on_and_its_manifest(tmp_path):
    out = tmp_path / "headmotion_blender.zip"
    assert main(["blender-addon", "-o", str(out)]) == 0
    names = zipfile.ZipFile(out).namelist()
    assert {n.split("/")[0] for n in names} == {ADDON_NAME}
    assert f"{ADDON_NAME}/__init__.py" in names and f"{ADDON_NAME}/blender_manifest.toml" in names
    manifest = tomllib.loads(zipfile.ZipFile(out).read(f"{ADDON_NAME}/blender_manifest.toml").decode())
    assert manifest["id"] == ADDON_NAME and manifest["type"] == "add-on" and manifest["version"] == headmotion.__version__
    assert manifest["blender_version_min"] == "4.2.0" and manifest["license"] == ["SPDX:MIT"]
    assert len(manifest["tagline"]) <= 64 and manifest["tagline"][-1].isalnum()
    init = zipfile.ZipFile(out).read(f"{ADDON_NAME}/__init__.py").decode()
    assert '"blender": (3, 4, 0)' in init and f'"version": ({headmotion.__version__.replace(".", ", ")})' in init
    assert write_addon(tmp_path / "again.zip").read_bytes() == out.read_bytes()  # the same add-on, the same bytes
    assert main(["blender-addon", "-o", str(tmp_path / "addon.tar")]) == 2


def test_bone_presets_and_names():
    b = _bones_module()
    chain = lambda *names: {n: (names[i - 1] if i else None) for i, n in enumerate(names)}  # noqa: E731
    assert b.find_neck_and_head(chain("Hips", "J_Bip_C_Neck", "J_Bip_C_Head"))[:2] == ("J_Bip_C_Neck", "J_Bip_C_Head")
    assert b.find_neck_and_head(chain("Hips", "mixamorig7:Neck", "mixamorig7:Head"))[:2] == \
        ("mixamorig7:Neck", "mixamorig7:Head")
    assert b.find_neck_and_head(chain("root", "neck_01", "neck_02", "head"))[:2] == ("neck_01", "head")
    assert b.find_neck_and_head(chain("spine.003", "spine.004", "spine.005", "spine.006"))[:2] == \
        ("spine.004", "spine.006")
    assert b.find_neck_and_head(chain("hips", "neck", "head"))[:2] == ("neck", "head")
    assert b.find_neck_and_head(chain("Root", "Head"))[:2] == (None, "Head")  # no neck: all on the head
    assert b.find_neck_and_head(chain("a", "b", "c"), vrm=("b", "c"))[:2] == ("b", "c")  # the VRM add-on's map
    assert b.find_neck_and_head(chain("a", "b", "c"), "CUSTOM", "a", "c")[:2] == ("a", "c")
    with pytest.raises(LookupError, match="no head bone found"):
        b.find_neck_and_head(chain("Bone", "Bone.001"))
    with pytest.raises(LookupError, match="no bone named 'x'"):
        b.find_neck_and_head(chain("a", "b"), "CUSTOM", "", "x")
    with pytest.raises(LookupError, match="not above the head bone"):
        b.find_neck_and_head({"r": None, "n": "r", "h": "r"}, "CUSTOM", "n", "h")


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.degrees((Rotation.from_matrix(a).inv() * Rotation.from_matrix(b)).magnitude())


@pytest.mark.slow
@pytest.mark.skipif(BLENDER is None, reason="blender is not installed (apt-get install blender)")
def test_keys_in_blender_equal_the_motion(tmp_path):
    exe = shutil.which("headmotion") or str(Path(sys.executable).with_name("headmotion"))
    zip_path = write_addon(tmp_path / "headmotion_blender.zip")
    out = tmp_path / "result.json"
    env = {"BLENDER_USER_SCRIPTS": str(tmp_path / "scripts"), "BLENDER_USER_CONFIG": str(tmp_path / "config")}
    import os

    run = subprocess.run([BLENDER, "-b", "--factory-startup", "-noaudio", "--python-exit-code", "1", "--python",
                          str(CHECK), "--", str(zip_path), exe, str(SPEECH), str(out)],
                         capture_output=True, text=True, timeout=600, env={**os.environ, **env})
    assert run.returncode == 0 and out.exists(), run.stdout[-3000:] + run.stderr[-3000:]
    res = json.loads(out.read_text())
    options = {"vroid": {"seed": 3, "amount": 1.5}, "ue": {"seed": 0}, "mixamo": {"seed": 1}}
    for name, rig in res["rigs"].items():
        fps = float(f"{rig['fps']:.10g}")  # as the add-on passes --fps
        motion = synthesize(SPEECH, seed=options[name]["seed"], amount=options[name].get("amount", 1.0), fps=fps)[0]
        assert rig["frames"] == len(motion), name
        expected = Rotation.from_rotvec(np.array(motion.rotvec)).as_matrix()
        got = M.T @ np.asarray(rig["head"]) @ M
        err = _angle_deg(got, expected)
        assert err.max() < 1.0, (name, err.max())
        print(f"{name}: head within {err.max():.2e} deg of the motion over {len(err)} frames")
        neck = M.T @ np.asarray(rig["neck"]) @ M
        share = Rotation.from_rotvec(rig["neck_share"] * np.array(motion.rotvec)).as_matrix()
        assert _angle_deg(neck, share).max() < 1.0, name
        assert np.degrees(np.linalg.norm(motion.rotvec, axis=1)).max() > 3.0  # the check can fail: it moves
    assert res["rigs"]["mixamo"]["first_key"] == 40.0  # keyed from the sound strip's frame
    assert res["rigs"]["ue"]["modes"] == ["YXZ", "AXIS_ANGLE"] and not res["rigs"]["ue"]["neck_02_keyed"]
    assert res["sound_strip"] == [[100.0, str(SPEECH)]]
    errors = res["errors"]
    assert all(e is not None and len(e.splitlines()) == 1 for e in errors.values()), errors
    assert "no head bone found" in errors["no_head"] and "not a readable audio file" in errors["bad_audio"]
    assert "not found" in errors["missing_audio"] and "not a program" in errors["no_headmotion"]
    assert "not found on PATH" in errors["not_on_path"] and "not an armature" in errors["no_armature"]
    assert res["keys_after_refusals"] == 0
