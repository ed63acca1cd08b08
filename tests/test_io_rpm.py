"""The Ready Player Me–style glTF writer (headmotion.io.rpm) and the avatar of the TalkingHead page it
writes (headmotion.web.talkinghead_avatar): every bone and morph target TalkingHead needs — the
bone names read from the bundled TalkingHead itself — in the Mixamo frames its poses assume, a skin
whose bind pose is the rest pose, morph targets that move what their names say, and the committed
talkinghead.glb equal to what the code builds."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_io_vrm import _glb

from headmotion.errors import ParameterError
from headmotion.io.rpm import (ARKIT_BLENDSHAPES, BONE_NAMES, BONES, MORPH_UNIT, QUANTIZATION, ROOT_NAME, RPM_EXTRAS,
                               VISEMES, SkinnedPart, rpm_bytes)
from headmotion.web.build_assets import TALKINGHEAD_FILE, talkinghead_bytes

VENDOR = TALKINGHEAD_FILE.parent / "vendor" / "talkinghead.js"


@pytest.fixture(scope="module")
def committed():
    return _glb(TALKINGHEAD_FILE.read_bytes())


def _accessor(doc, blob, i) -> np.ndarray:
    """An accessor's values as floats (normalised integers scaled, sparse ones filled in)."""
    acc = doc["accessors"][i]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc["type"]]
    dtype = {5126: np.float32, 5123: np.uint16, 5121: np.uint8, 5125: np.uint32, 5122: np.int16, 5120: np.int8}
    scale = {5122: 32767.0, 5120: 127.0, 5121: 255.0, 5123: 65535.0}.get(acc["componentType"], 1.0)

    def read(view_i, ctype, count, w):
        view = doc["bufferViews"][view_i]
        stride = view.get("byteStride")
        a = np.frombuffer(blob, dtype[ctype], offset=view.get("byteOffset", 0), count=view["byteLength"] // dtype[ctype]().itemsize)
        return a.reshape(count, -1)[:, :w] if stride else a[: count * w].reshape(count, w)

    out = np.zeros((acc["count"], width))
    if "bufferView" in acc:
        out = read(acc["bufferView"], acc["componentType"], acc["count"], width).astype(float)
    if "sparse" in acc:
        sp = acc["sparse"]
        idx = read(sp["indices"]["bufferView"], sp["indices"]["componentType"], sp["count"], 1).ravel()
        out[idx] = read(sp["values"]["bufferView"], acc["componentType"], sp["count"], width)
    if acc.get("normalized"):
        out = out / scale
    return out


def _nodes(doc):
    return {n["name"]: i for i, n in enumerate(doc["nodes"])}


def _world(doc):
    """Each node's world matrix at rest."""
    parent = {c: i for i, n in enumerate(doc["nodes"]) for c in n.get("children", [])}
    out = {}

    def m(i):
        if i not in out:
            n = doc["nodes"][i]
            local = np.eye(4)
            local[:3, :3] = Rotation.from_quat(n.get("rotation", [0, 0, 0, 1])).as_matrix()
            local[:3, 3] = n.get("translation", [0, 0, 0])
            out[i] = (m(parent[i]) if i in parent else np.eye(4)) @ local
        return out[i]

    return {n["name"]: m(i) for i, n in enumerate(doc["nodes"])}


def test_every_bone_talkinghead_poses_is_there(committed):
    doc, _ = committed
    js = VENDOR.read_text(encoding="utf-8")
    posed = set(re.findall(r"""['"]([A-Z][A-Za-z0-9]+)\.(?:rotation|position|quaternion)['"]""", js))
    assert {"Hips", "Spine2", "Neck", "Head", "LeftHandPinky3", "RightToeBase"} <= posed  # read from its poses
    assert js.count("Armature") >= 1 and "LeftEye" in js
    names = set(_nodes(doc))
    assert posed | {ROOT_NAME, "LeftEye", "RightEye"} <= names
    assert set(BONE_NAMES) <= names
    assert doc["nodes"][doc["scenes"][0]["nodes"][0]]["name"] == ROOT_NAME  # the root TalkingHead looks for
    skin = doc["skins"][0]
    assert [doc["nodes"][j]["name"] for j in skin["joints"]] == list(BONE_NAMES)
    assert doc["extras"]["neck_share"] == pytest.approx(0.93) and QUANTIZATION in doc["extensionsRequired"]


def test_bones_have_the_mixamo_frames_and_stand_on_the_floor(committed):
    doc, blob = committed
    w = _world(doc)
    up = lambda n: w[n][:3, 1]  # noqa: E731  the bone's +y in the world
    for n in ("Hips", "Spine", "Spine1", "Spine2", "Neck", "Head"):
        np.testing.assert_allclose(w[n][:3, :3], np.eye(3), atol=1e-6)  # the avatar's axes: +x left, +z forward
    for side, sx in (("Left", 1), ("Right", -1)):
        for n in ("Shoulder", "Arm", "ForeArm", "Hand", "HandIndex1"):
            np.testing.assert_allclose(up(side + n), [sx, 0, 0], atol=1e-6)  # out along the arm
            np.testing.assert_allclose(w[side + n][:3, 2], [0, -1, 0], atol=1e-6)  # +z down
        for n in ("UpLeg", "Leg"):
            np.testing.assert_allclose(up(side + n), [0, -1, 0], atol=1e-6)
            np.testing.assert_allclose(w[side + n][:3, 0], [-1, 0, 0], atol=1e-6)
        assert up(side + "Foot")[2] > 0.8 and up(side + "ToeBase")[2] > 0.99  # forward
        # each limb bone's child lies along its +y, as the poses of those avatars assume
        for b in ("ForeArm", "Hand", "Leg", "Foot", "ToeBase"):
            t = doc["nodes"][_nodes(doc)[side + b]]["translation"]
            assert abs(t[0]) < 1e-6 and abs(t[2]) < 1e-6 and t[1] > 0.1, (side + b, t)
    body = doc["meshes"][[m["name"] for m in doc["meshes"]].index("Body")]["primitives"][0]
    pos = _accessor(doc, blob, body["attributes"]["POSITION"])
    assert abs(pos[:, 1].min()) < 0.005  # the soles on the floor (TalkingHead balances the hips on them)
    assert 1.65 < w["LeftEye"][1, 3] < 1.75 and w["LeftEye"][0, 3] > 0  # the avatar's left eye at +x


def test_the_bind_pose_is_the_rest_pose(committed):
    """Inverse bind matrices are the inverses of the bones' world transforms at rest: a skinned vertex
    stays where it is stored."""
    doc, blob = committed
    w = _world(doc)
    skin = doc["skins"][0]
    ibm = _accessor(doc, blob, skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    for k, j in enumerate(skin["joints"]):
        np.testing.assert_allclose(w[doc["nodes"][j]["name"]] @ ibm[k], np.eye(4), atol=1e-5)
    for mesh in doc["meshes"]:
        a = mesh["primitives"][0]["attributes"]
        wt = _accessor(doc, blob, a["WEIGHTS_0"])
        np.testing.assert_allclose(wt.sum(axis=1), 1.0, atol=1e-6)


def _morphs(doc, blob, mesh_name):
    mesh = doc["meshes"][[m["name"] for m in doc["meshes"]].index(mesh_name)]
    prim = mesh["primitives"][0]
    pos = _accessor(doc, blob, prim["attributes"]["POSITION"])
    return pos, {n: _accessor(doc, blob, t["POSITION"]) for n, t in zip(mesh["extras"]["targetNames"], prim["targets"])}


def test_the_blendshapes_and_visemes_are_there_and_move_what_they_say(committed):
    doc, blob = committed
    names = set()
    for m in doc["meshes"]:
        names |= set((m.get("extras") or {}).get("targetNames", []))
    assert set(ARKIT_BLENDSHAPES) | set(VISEMES) | set(RPM_EXTRAS) <= names
    assert len(ARKIT_BLENDSHAPES) == 52 and len(VISEMES) == 15
    pos, face = _morphs(doc, blob, "Face")
    head_y = _world(doc)["Head"][1, 3]
    chin = np.argmin(np.where((np.abs(pos[:, 0]) < 0.005) & (pos[:, 2] > 0.05), pos[:, 1], np.inf))  # low, in front
    assert face["jawOpen"][chin, 1] < -0.01  # the chin drops a centimetre or more
    forehead = np.flatnonzero((pos[:, 1] > head_y + 0.1) & (pos[:, 2] > 0.08))
    assert len(forehead) and np.abs(face["jawOpen"][forehead]).max() < 1e-6  # the top of the face stays
    assert np.abs(face["viseme_sil"]).max() == 0 and np.abs(face["viseme_aa"]).max() > 0.005
    lip = face["mouthSmileLeft"]
    moved = np.linalg.norm(lip, axis=1) > 0.001
    assert pos[moved, 0].mean() > 0.01 and lip[moved, 1].mean() > 0  # the avatar's left corner goes up
    assert np.abs(np.round(lip / MORPH_UNIT) * MORPH_UNIT - lip).max() < 1e-9  # stored as int16 steps
    eye, e = _morphs(doc, blob, "EyeLeft")
    front = np.argmax(eye[:, 2])  # the pupil
    assert e["eyeLookUpLeft"][front, 1] > 0.003 and e["eyeLookOutLeft"][front, 0] > 0.003  # up; out to +x
    assert e["eyeLookInLeft"][front, 0] < -0.003 and e["eyeBlinkLeft"][np.argmax(eye[:, 1]), 1] < -0.005


def test_the_committed_avatar_is_what_the_code_builds(committed):
    doc, _ = committed
    fresh_bytes = talkinghead_bytes()
    fresh, _ = _glb(fresh_bytes)
    for key in ("nodes", "skins", "meshes", "accessors", "extras"):
        assert doc[key] == fresh[key], key
    assert len(TALKINGHEAD_FILE.read_bytes()) == len(fresh_bytes)


def _part(**change):
    pos = np.array([[0, 1.6, 0], [0.1, 1.6, 0], [0, 1.7, 0]], float)
    j = np.zeros((3, 4), np.uint8)
    j[:, 0] = BONE_NAMES.index("Head")
    w = np.zeros((3, 4))
    w[:, 0] = 1
    args = dict(name="t", positions=pos, normals=np.tile([0, 0, 1.0], (3, 1)), colors=np.full((3, 3), 0.5), joints=j,
                weights=w, indices=np.array([[0, 1, 2]]), morphs={"jawOpen": np.full((3, 3), 0.01), "viseme_sil": None})
    return SkinnedPart(**{**args, **change})


def test_a_small_avatar_round_trips_and_bad_input_is_refused():
    doc, blob = _glb(rpm_bytes([_part()]))
    _, m = _morphs(doc, blob, "t")
    np.testing.assert_allclose(m["jawOpen"], 0.01, atol=MORPH_UNIT)
    assert not m["viseme_sil"].any() and "bufferView" not in doc["accessors"][doc["meshes"][0]["primitives"][0]["targets"][1]["POSITION"]]
    assert len(BONES) == len(doc["skins"][0]["joints"])
    with pytest.raises(ParameterError, match="sum to 1"):
        rpm_bytes([_part(weights=np.full((3, 4), 0.5))])
    with pytest.raises(ParameterError, match="indices"):
        rpm_bytes([_part(indices=np.array([[0, 1, 5]]))])
    with pytest.raises(ParameterError, match="jawOpen"):
        rpm_bytes([_part(morphs={"jawOpen": np.zeros((2, 3))})])
    with pytest.raises(ParameterError, match="neck_share"):
        rpm_bytes([_part()], neck_share=2)
