"""A Ready Player Me–style full-body avatar as binary glTF: the skeleton, the bone names and the
morph targets that TalkingHead (``@met4citizen/talkinghead``) and other Ready Player Me players
drive.

What is written
---------------
A root node ``Armature`` holding the bone tree — the Mixamo names Ready Player Me uses, ``Hips →
Spine → Spine1 → Spine2 → Neck → Head`` (with ``LeftEye``, ``RightEye``), the shoulders, arms,
hands, three joints per finger, the legs, feet and toes (:data:`BONES`) — and the skinned meshes,
each with its own morph targets, named in ``mesh.extras.targetNames`` (three.js's GLTFLoader reads
them as ``morphTargetDictionary``).  A morph target is stored as a sparse accessor of only the
vertices it moves, its displacements as normalised 16-bit integers of :data:`MORPH_UNIT` metres
(``KHR_mesh_quantization``, which also stores the normals as normalised bytes), or as an accessor of zeros when it moves none; morph targets carry
positions only.

Bone frames follow the Mixamo convention of those avatars, so that a player's poses, given as
local rotations of each bone, bend this skeleton as they bend theirs: the rest pose is a T-pose;
the spine, neck, head and eyes have the avatar's axes (+x its left, +y up, +z forward — the
project's, :mod:`headmotion.rotations`); a shoulder, arm, hand and finger bone points its +y out
along the limb with +z down (+x backwards on the left side, forwards on the right); a leg bone
points +y down with +x to the avatar's right; a foot points +y from the ankle to the ball of the
foot and a toe +y forward.  :data:`BONES` gives each bone's world position and frame at rest; the
file holds them as local translations and rotations, and the skin's inverse bind matrices are the
inverses of the rest transforms.

A player splits a head rotation between ``Neck`` and ``Head`` as the BVH writer does
(:mod:`headmotion.io.vrm`); the share is stored in the root ``extras.neck_share`` (three.js exposes
it as ``gltf.userData.neck_share``) and in ``asset.extras``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError
from .gltf import _gltf

#: world frames at rest: (x, y, z) axes of the bone as columns
_UP = np.eye(3)
_LEFT_ARM = np.array([[0, 1, 0], [0, 0, -1], [-1, 0, 0]], float)    # x back, y left (+x), z down
_RIGHT_ARM = np.array([[0, -1, 0], [0, 0, -1], [1, 0, 0]], float)   # x forward, y right (-x), z down
_LEG = np.diag([-1.0, -1.0, 1.0])                                  # x right, y down, z forward
_TOE = np.array([[-1, 0, 0], [0, 0, 1], [0, 1, 0]], float)          # x right, y forward, z up


def _foot(toward) -> np.ndarray:
    """A foot's frame: +y from the ankle toward the ball of the foot, +x to the avatar's right."""
    y = np.asarray(toward, float) / np.linalg.norm(toward)
    x = np.array([-1.0, 0.0, 0.0])
    return np.stack([x, y, np.cross(x, y)], axis=1)


#: the hip, ankle and ball of the left foot (m)
_HIP, _ANKLE, _BALL = (0.09, 0.93, 0.0), (0.09, 0.09, 0.0), (0.09, 0.025, 0.13)
_FOOT = _foot(np.subtract(_BALL, _ANKLE))
#: left-side bones: (name, parent, world position at rest (m), world frame)
_LEFT = [
    ("LeftShoulder", "Spine2", (0.04, 1.46, 0.0), _LEFT_ARM),
    ("LeftArm", "LeftShoulder", (0.17, 1.46, 0.0), _LEFT_ARM),
    ("LeftForeArm", "LeftArm", (0.45, 1.46, 0.0), _LEFT_ARM),
    ("LeftHand", "LeftForeArm", (0.71, 1.46, 0.0), _LEFT_ARM),
    *[(f"LeftHand{f}{k}", f"LeftHand{f}{k - 1}" if k > 1 else "LeftHand",
       (x0 + sum(seg[:k - 1]), 1.46 + dy, z), _LEFT_ARM)
      for f, x0, dy, z, seg in (("Thumb", 0.735, -0.012, 0.035, (0.03, 0.025)),
                                ("Index", 0.80, 0.0, 0.026, (0.035, 0.025)),
                                ("Middle", 0.805, 0.0, 0.008, (0.038, 0.027)),
                                ("Ring", 0.80, 0.0, -0.010, (0.035, 0.025)),
                                ("Pinky", 0.79, 0.0, -0.027, (0.027, 0.02)))
      for k in (1, 2, 3)],
    ("LeftUpLeg", "Hips", _HIP, _LEG),
    ("LeftLeg", "LeftUpLeg", (0.09, 0.51, 0.0), _LEG),
    ("LeftFoot", "LeftLeg", _ANKLE, _FOOT),
    ("LeftToeBase", "LeftFoot", _BALL, _TOE),
    ("LeftEye", "Head", (0.031, 1.692, 0.086), _UP),
]


def _mirrored(name, parent, pos, frame):
    """The right-side twin of a left-side bone: its position mirrored in x and its frame
    kept right-handed: an arm's +y points out to the right and its +x forwards; the legs, feet, toes
    and eyes have the left side's frames."""
    f = _RIGHT_ARM if frame is _LEFT_ARM else frame
    return (name.replace("Left", "Right"), parent.replace("Left", "Right"), (-pos[0], pos[1], pos[2]), f)


#: every bone: (name, parent name or None, world position at rest (m), world frame at rest (3×3,
#: the bone's axes as columns)); parents come before their children
BONES = (
    ("Hips", None, (0.0, 1.00, 0.0), _UP),
    ("Spine", "Hips", (0.0, 1.10, 0.0), _UP),
    ("Spine1", "Spine", (0.0, 1.22, 0.0), _UP),
    ("Spine2", "Spine1", (0.0, 1.35, 0.0), _UP),
    ("Neck", "Spine2", (0.0, 1.50, 0.0), _UP),
    ("Head", "Neck", (0.0, 1.60, 0.0), _UP),
    *_LEFT,
    *[_mirrored(*b) for b in _LEFT],
)
BONE_NAMES = tuple(b[0] for b in BONES)
ROOT_NAME = "Armature"

#: the 52 ARKit blendshapes (Apple's ARFaceAnchor.BlendShapeLocation names)
ARKIT_BLENDSHAPES = (
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft", "eyeSquintLeft",
    "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight", "eyeLookOutRight", "eyeLookUpRight",
    "eyeSquintRight", "eyeWideRight", "jawForward", "jawLeft", "jawRight", "jawOpen", "mouthClose",
    "mouthFunnel", "mouthPucker", "mouthLeft", "mouthRight", "mouthSmileLeft", "mouthSmileRight",
    "mouthFrownLeft", "mouthFrownRight", "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft",
    "mouthStretchRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper",
    "mouthPressLeft", "mouthPressRight", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight",
    "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft", "noseSneerRight", "tongueOut",
)
#: the 15 Oculus (Meta) lip-sync visemes, with Ready Player Me's ``viseme_`` prefix
VISEMES = tuple(f"viseme_{v}" for v in ("sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR",
                                        "aa", "E", "I", "O", "U"))
#: Ready Player Me's own additions to ARKit's set
RPM_EXTRAS = ("mouthOpen", "mouthSmile", "eyesClosed", "eyesLookUp", "eyesLookDown")

#: a morph target leaves out the vertices it moves less than this (m)
MIN_MOVE = 1e-4
#: a morph target's resolution: normalised int16 in [-1, 1] metres
MORPH_UNIT = 1.0 / 32767
QUANTIZATION = "KHR_mesh_quantization"

_FLOAT, _BYTE, _SHORT, _USHORT, _UBYTE, _UINT = 5126, 5120, 5122, 5123, 5121, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


@dataclass
class SkinnedPart:
    """One skinned mesh of the avatar, in world coordinates at rest (metres, +y up, +z forward).

    ``joints``/``weights``: ``(N, 4)`` bone names' indices in :data:`BONES` and weights summing to
    1; ``colors`` sRGB in [0, 1]; ``indices`` ``(M, 3)`` counter-clockwise seen from outside;
    ``morphs``: name → ``(N, 3)`` displacement (m) at weight 1."""

    name: str
    positions: np.ndarray
    normals: np.ndarray
    colors: np.ndarray
    joints: np.ndarray
    weights: np.ndarray
    indices: np.ndarray
    morphs: dict = field(default_factory=dict)


def bone_index(name: str) -> int:
    return BONE_NAMES.index(name)


def rest_transforms():
    """Each bone's local translation and rotation (x, y, z, w quaternion) at rest, from :data:`BONES`."""
    from scipy.spatial.transform import Rotation

    pos = {n: np.asarray(p, float) for n, _, p, _ in BONES}
    frame = {n: np.asarray(f, float) for n, _, _, f in BONES}
    out = []
    for name, parent, _, _ in BONES:
        if parent is None:
            t, r = pos[name], frame[name]
        else:
            t, r = frame[parent].T @ (pos[name] - pos[parent]), frame[parent].T @ frame[name]
        out.append((t, Rotation.from_matrix(r).as_quat()))
    return out


def _check(part: SkinnedPart) -> None:
    n = len(part.positions)
    shapes = {"positions": (n, 3), "normals": (n, 3), "colors": (n, 3), "joints": (n, 4), "weights": (n, 4)}
    for key, shape in shapes.items():
        if np.shape(getattr(part, key)) != shape:
            raise ParameterError(f"{part.name}: {key} must have shape {shape}; got {np.shape(getattr(part, key))}")
    idx = np.asarray(part.indices)
    if n == 0 or idx.ndim != 2 or idx.shape[1] != 3 or idx.min() < 0 or idx.max() >= n:
        raise ParameterError(f"{part.name}: indices must be (M, 3) triangles of vertices 0..{n - 1}")
    if np.asarray(part.joints).max() >= len(BONES):
        raise ParameterError(f"{part.name}: joints must index BONES (0..{len(BONES) - 1})")
    if not np.allclose(np.sum(part.weights, axis=1), 1.0, atol=1e-4):
        raise ParameterError(f"{part.name}: every vertex's weights must sum to 1")
    for key, d in part.morphs.items():
        if d is not None and np.shape(d) != (n, 3):
            raise ParameterError(f"{part.name}: morph target {key} must have shape {(n, 3)}")


def _unit_bytes(w) -> np.ndarray:
    """Weights as normalised bytes whose rows sum to exactly 255 (the largest takes the rounding)."""
    b = np.round(np.asarray(w, float) * 255).astype(np.int64)
    top = np.argmax(b, axis=1)
    b[np.arange(len(b)), top] += 255 - b.sum(axis=1)
    return b.astype(np.uint8)


def build_rpm(parts, *, name: str = "headmotion avatar", neck_share: float | None = None,
              extras: dict | None = None, min_move: float = MIN_MOVE):
    """The glTF document (a ``pygltflib.GLTF2`` with its binary blob) of an avatar made of
    :class:`SkinnedPart` s on :data:`BONES`.  A morph target leaves out the vertices it moves by
    less than ``min_move`` metres."""
    from .bvh import DEFAULT_NECK_SHARE
    from .vrm import _srgb_to_linear

    g = _gltf()
    s = DEFAULT_NECK_SHARE if neck_share is None else float(neck_share)
    if not 0.0 <= s <= 1.0:
        raise ParameterError(f"neck_share must be in [0, 1]; got {neck_share!r}")
    for p in parts:
        _check(p)
    blob = bytearray()
    views, accessors = [], []

    def view(arr, target=None, stride=None) -> int:
        arr = np.ascontiguousarray(arr)
        while len(blob) % 4:
            blob.append(0)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=arr.nbytes, target=target,
                                  byteStride=stride))
        blob.extend(arr.tobytes())
        return len(views) - 1

    def add(arr, kind, ctype, *, target=None, minmax=False, normalized=False) -> int:
        acc = g.Accessor(bufferView=view(arr, target), componentType=ctype, count=int(arr.shape[0]), type=kind,
                         normalized=normalized or None)
        if minmax:
            flat = np.asarray(arr).reshape(arr.shape[0], -1)
            acc.min = [float(x) for x in flat.min(axis=0)]
            acc.max = [float(x) for x in flat.max(axis=0)]
        accessors.append(acc)
        return len(accessors) - 1

    def morph(d, n) -> int:
        """A sparse accessor of the vertices ``d`` moves (zeros elsewhere), in MORPH_UNITs."""
        d = np.zeros((n, 3)) if d is None else np.asarray(d, float)
        moved = np.flatnonzero(np.linalg.norm(d, axis=1) >= min_move)
        q = np.clip(np.round(d[moved] / MORPH_UNIT), -32767, 32767).astype(np.int16)
        lo, hi = (q.min(0), q.max(0)) if len(moved) else (np.zeros(3), np.zeros(3))
        acc = g.Accessor(componentType=_SHORT, normalized=True, count=n, type="VEC3",
                         min=[int(x) for x in np.minimum(lo, 0)], max=[int(x) for x in np.maximum(hi, 0)])
        if len(moved):
            wide = n > 65535
            acc.sparse = g.Sparse(count=len(moved), indices=g.AccessorSparseIndices(
                bufferView=view(moved.astype(np.uint32 if wide else np.uint16)),
                componentType=_UINT if wide else _USHORT), values=g.AccessorSparseValues(bufferView=view(q)))
        accessors.append(acc)
        return len(accessors) - 1

    def normals(n) -> int:
        """Unit normals as normalised int8, each padded to 4 bytes (``KHR_mesh_quantization``)."""
        q = np.zeros((len(n), 4), np.int8)
        q[:, :3] = np.clip(np.round(np.asarray(n, float) * 127), -127, 127)
        accessors.append(g.Accessor(bufferView=view(q, _ARRAY_BUFFER, stride=4), componentType=_BYTE,
                                    normalized=True, count=len(n), type="VEC3"))
        return len(accessors) - 1

    meshes, materials = [], []
    for p in parts:
        pos = np.asarray(p.positions, np.float32)
        rgba = np.concatenate([np.round(_srgb_to_linear(p.colors) * 255), np.full((len(pos), 1), 255)], axis=1)
        attrs = g.Attributes(
            POSITION=add(pos, "VEC3", _FLOAT, target=_ARRAY_BUFFER, minmax=True),
            NORMAL=normals(p.normals),
            COLOR_0=add(rgba.astype(np.uint8), "VEC4", _UBYTE, target=_ARRAY_BUFFER, normalized=True),
            JOINTS_0=add(np.asarray(p.joints, np.uint8), "VEC4", _UBYTE, target=_ARRAY_BUFFER),
            WEIGHTS_0=add(_unit_bytes(p.weights), "VEC4", _UBYTE, target=_ARRAY_BUFFER, normalized=True))
        idx = np.asarray(p.indices)
        big = len(pos) > 65535
        a_idx = add(idx.astype(np.uint32 if big else np.uint16).ravel(), "SCALAR", _UINT if big else _USHORT,
                    target=_ELEMENT_ARRAY_BUFFER, minmax=True)
        names = list(p.morphs)
        targets = [{"POSITION": morph(p.morphs[k], len(pos))} for k in names]
        materials.append(g.Material(name=p.name, pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=0.0, roughnessFactor=0.75)))
        prim = g.Primitive(attributes=attrs, indices=a_idx, material=len(materials) - 1, targets=targets or None)
        meshes.append(g.Mesh(name=p.name, primitives=[prim], weights=[0.0] * len(names) or None,
                             extras={"targetNames": names} if names else None))

    rest = rest_transforms()
    world = np.array([b[2] for b in BONES], float)
    frames = np.array([b[3] for b in BONES], float)
    ibm = np.tile(np.eye(4), (len(BONES), 1, 1))
    ibm[:, :3, :3] = np.transpose(frames, (0, 2, 1))
    ibm[:, :3, 3] = -np.einsum("kji,kj->ki", frames, world)       # Rᵀ(−p)
    a_ibm = add(np.transpose(ibm, (0, 2, 1)).reshape(len(BONES), 16).astype(np.float32), "MAT4", _FLOAT)

    nodes = [g.Node(name=ROOT_NAME, children=[1, *range(1 + len(BONES), 1 + len(BONES) + len(parts))])]
    for (bone, _, _, _), (t, q) in zip(BONES, rest):
        kids = [1 + j for j, b in enumerate(BONES) if b[1] == bone]
        rot = None if np.allclose(q, [0, 0, 0, 1]) else [round(float(x), 7) for x in q]
        nodes.append(g.Node(name=bone, translation=[round(float(x), 6) for x in t], rotation=rot,
                            children=kids or None))
    for k, p in enumerate(parts):
        nodes.append(g.Node(name=p.name, mesh=k, skin=0))
    doc = g.GLTF2(
        asset=g.Asset(version="2.0", generator="headmotion.io.rpm",
                      extras={"neck_share": s, "axes": "+Y up, +Z forward, +X the avatar's left", **(extras or {})}),
        extras={"neck_share": s},
        extensionsUsed=[QUANTIZATION],
        extensionsRequired=[QUANTIZATION],
        scene=0,
        scenes=[g.Scene(name=name, nodes=[0])],
        nodes=nodes,
        meshes=meshes,
        materials=materials,
        skins=[g.Skin(name="Armature", joints=list(range(1, 1 + len(BONES))), skeleton=1,
                      inverseBindMatrices=a_ibm)],
        accessors=accessors,
        bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob))],
    )
    doc.set_binary_blob(bytes(blob))
    return doc


def rpm_bytes(parts, **kwargs) -> bytes:
    """:func:`build_rpm` as the bytes of a ``.glb`` file."""
    return b"".join(build_rpm(parts, **kwargs).save_to_bytes())


__all__ = ["build_rpm", "rpm_bytes", "SkinnedPart", "BONES", "BONE_NAMES", "ROOT_NAME", "ARKIT_BLENDSHAPES",
           "VISEMES", "RPM_EXTRAS", "MORPH_UNIT", "MIN_MOVE", "bone_index", "rest_transforms"]
