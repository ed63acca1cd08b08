"""The VRM 1.0 writer (headmotion.io.vrm) and the avatar it writes for the avatar page: the humanoid
map VRM requires, a T-pose at rest, skin weights that move head vertices rigidly with the full head
rotation when the bones take the BVH writer's neck/head split, and the committed avatar.vrm equal to
what the code builds."""

from __future__ import annotations

import json
import struct

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.errors import FormatError, ParameterError
from headmotion.io.vrm import BONES, REQUIRED_BONES, VRM_EXTENSION, save_vrm, skin_weights, vrm_bytes


def _glb(data: bytes):
    """The JSON chunk and the binary chunk of a GLB file."""
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2 and length == len(data)
    n_json, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON"
    doc = json.loads(data[20:20 + n_json])
    n_bin, kind = struct.unpack_from("<I4s", data, 20 + n_json)
    assert kind == b"BIN\0"
    return doc, data[28 + n_json:28 + n_json + n_bin]


def _accessor(doc, blob, i):
    acc = doc["accessors"][i]
    view = doc["bufferViews"][acc["bufferView"]]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc["type"]]
    dtype = {5126: np.float32, 5123: np.uint16, 5121: np.uint8, 5125: np.uint32}[acc["componentType"]]
    a = np.frombuffer(blob, dtype, acc["count"] * width, view.get("byteOffset", 0) + acc.get("byteOffset", 0))
    return a.reshape(acc["count"], width) if width > 1 else a


def _cube_bust():
    """A head cube (weight 1) above the origin and a torso cube (weight 0) below it."""
    corners = np.array([[x, y, z] for x in (-0.05, 0.05) for y in (0.0, 0.1) for z in (-0.05, 0.05)], np.float32)
    pos = np.concatenate([corners + [0, 0.02, 0], corners - [0, 0.3, 0]])
    tris = np.array([[0, 1, 3], [0, 3, 2]])
    return pos, pos / np.linalg.norm(pos, axis=1, keepdims=True), np.full((16, 3), 0.5), \
        np.r_[np.ones(8), np.zeros(8)], np.concatenate([tris, tris + 8])


def _skinned(doc, blob, rotvec, share):
    """Vertex positions with the neck at exp(s·r) and the head at exp((1 − s)·r), by the file's skin."""
    names = [n["name"] for n in doc["nodes"]]
    parent = {c: i for i, n in enumerate(doc["nodes"]) for c in n.get("children", [])}
    local = {names.index("neck"): Rotation.from_rotvec(share * np.asarray(rotvec)),
             names.index("head"): Rotation.from_rotvec((1 - share) * np.asarray(rotvec))}
    world = {}

    def matrix(i):
        if i not in world:
            m = np.eye(4)
            m[:3, :3] = local.get(i, Rotation.identity()).as_matrix()
            m[:3, 3] = doc["nodes"][i]["translation"]
            world[i] = (matrix(parent[i]) if i in parent else np.eye(4)) @ m
        return world[i]

    prim = doc["meshes"][0]["primitives"][0]["attributes"]
    pos = _accessor(doc, blob, prim["POSITION"]).astype(float)
    joints, weights = _accessor(doc, blob, prim["JOINTS_0"]), _accessor(doc, blob, prim["WEIGHTS_0"])
    skin = doc["skins"][0]
    ibm = _accessor(doc, blob, skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
    joint_m = np.array([matrix(j) @ ibm[k] for k, j in enumerate(skin["joints"])])
    h = np.c_[pos, np.ones(len(pos))]
    out = np.einsum("nk,nkij,nj->ni", weights, joint_m[joints], h)
    return pos, out[:, :3]


def test_the_humanoid_map_holds_every_required_bone_at_rest_in_t_pose():
    doc, _ = _glb(vrm_bytes(*_cube_bust()))
    vrm = doc["extensions"][VRM_EXTENSION]
    assert doc["extensionsUsed"] == [VRM_EXTENSION] and vrm["specVersion"] == "1.0"
    bones = vrm["humanoid"]["humanBones"]
    assert REQUIRED_BONES <= set(bones) and {"neck", "chest"} <= set(bones)
    for name, ref in bones.items():
        node = doc["nodes"][ref["node"]]
        assert node["name"] == name and "rotation" not in node  # identity rest rotations (VRM 1.0 T-pose)
    meta = vrm["meta"]
    assert meta["name"] and meta["authors"] and meta["licenseUrl"].startswith("https://vrm.dev/licenses/1.0")
    assert doc["asset"]["extras"]["neck_share"] == pytest.approx(0.93)


def test_skin_weights_split_along_the_neck():
    names = [b[0] for b in BONES]
    j, w = skin_weights(np.array([0.0, 0.25, 0.5, 0.75, 1.0]))
    np.testing.assert_allclose(w.sum(axis=1), 1.0)
    chest, neck, head = names.index("chest"), names.index("neck"), names.index("head")
    assert (j[0, 0], w[0, 0]) == (chest, 1.0)
    assert list(j[1, :2]) == [chest, neck] and list(w[1, :2]) == [0.5, 0.5]
    assert (j[2, 1], w[2, 1]) == (neck, 1.0)
    assert list(j[3, :2]) == [neck, head] and list(w[3, :2]) == [0.5, 0.5]
    assert (j[4, 1], w[4, 1]) == (head, 1.0)


@pytest.mark.parametrize("rotvec", [(0.0, 0.35, 0.0), (0.26, -0.1, 0.05), (-0.2, 0.3, -0.25)])
def test_the_split_turns_the_head_by_the_whole_rotation_and_leaves_the_torso(rotvec):
    doc, blob = _glb(vrm_bytes(*_cube_bust()))
    share = doc["asset"]["extras"]["neck_share"]
    rest, posed = _skinned(doc, blob, rotvec, share)
    # head vertices: rigid, turned by exp(r) (their differences rotate by the whole rotation)
    r = Rotation.from_rotvec(rotvec).as_matrix()
    np.testing.assert_allclose(posed[1:8] - posed[0], (rest[1:8] - rest[0]) @ r.T, atol=1e-5)
    np.testing.assert_allclose(posed[8:], rest[8:], atol=1e-6)  # the torso stays
    # positive yaw turns the nose (+z) to the avatar's left (+x)
    if rotvec == (0.0, 0.35, 0.0):
        front = posed[[1, 3, 5, 7]].mean(0) - posed[[0, 2, 4, 6]].mean(0)
        assert front[0] > 0


def test_bad_input_is_refused(tmp_path):
    pos, nrm, col, w, idx = _cube_bust()
    with pytest.raises(FormatError, match=r"\.vrm"):
        save_vrm(tmp_path / "a.glb", pos, nrm, col, w, idx)
    with pytest.raises(ParameterError, match="neck_share"):
        vrm_bytes(pos, nrm, col, w, idx, neck_share=1.5)
    with pytest.raises(ParameterError, match="head_weight"):
        vrm_bytes(pos, nrm, col, w[:3], idx)
    with pytest.raises(ParameterError, match="indices"):
        vrm_bytes(pos, nrm, col, w, idx + 100)
    assert not list(tmp_path.iterdir())  # nothing half-written
    save_vrm(tmp_path / "a.vrm", pos, nrm, col, w, idx)
    assert (tmp_path / "a.vrm").read_bytes() == vrm_bytes(pos, nrm, col, w, idx)


def test_the_committed_avatar_is_what_the_code_builds():
    from headmotion.web.build_assets import AVATAR_FILE, avatar_bytes

    committed, _ = _glb(AVATAR_FILE.read_bytes())
    fresh_bytes = avatar_bytes()
    fresh, _ = _glb(fresh_bytes)
    assert committed["extensions"] == fresh["extensions"] and committed["nodes"] == fresh["nodes"]
    assert committed["accessors"] == fresh["accessors"]  # counts, bounds (positions to float32)
    assert len(AVATAR_FILE.read_bytes()) == len(fresh_bytes)
