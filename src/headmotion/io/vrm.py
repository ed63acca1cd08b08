"""VRM 1.0 export: a bust avatar whose neck and head bones a player drives with head motion.

VRM is glTF 2.0 with the ``VRMC_vrm`` extension (https://github.com/vrm-c/vrm-specification,
``specification/VRMC_vrm-1.0``): author metadata and a humanoid bone map.  ``@pixiv/three-vrm``,
UniVRM, VSeeFace, Warudo and the VRM Blender add-on load it.  :func:`build_vrm` writes the
skeleton of :mod:`headmotion.io.gltf` (the VRM bone names ``hips → spine → chest → neck → head``)
with the arms and legs the humanoid map requires, in the T-pose VRM 1.0 asks for (every rest
rotation the identity), and one skinned mesh given by the caller: a bust whose vertices carry a
*head weight* (1 moves with the head, 0 with the chest, between: blended along the neck), as
:func:`headmotion.render.mesh.build_head_mesh` makes (``headmotion.web.build_assets`` writes the
avatar of the avatar page from it).  The arm and leg bones bind no vertex: the avatar is a bust.

Axes: VRM 1.0 models face +Z with +Y up, so +X is the model's left — the project's axes
(:mod:`headmotion.rotations`), as in :mod:`headmotion.io.gltf`.  A player splits a rotation vector
``r`` between the bones as the BVH and glTF writers do: the neck ``exp(s·r)``, the head
``exp((1−s)·r)`` (the same axis, so ``neck ∘ head = exp(r)``); ``s`` is stored in
``asset.extras.neck_share`` (default :data:`headmotion.io.bvh.DEFAULT_NECK_SHARE`).

Skinning of a vertex with head weight ``w``: ``w ≤ ½`` blends chest (``1 − 2w``) and neck
(``2w``), ``w > ½`` neck (``2 − 2w``) and head (``2w − 1``); the head bone sits at the mesh's
origin (the top of the neck), the neck bone :data:`NECK_BELOW_HEAD` below it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import FormatError, ParameterError
from .atomic import atomic_open
from .gltf import _gltf

#: where the mesh's origin (the head bone) stands, metres above the floor
HEAD_HEIGHT = 1.45
#: the neck bone, this far below the head bone (m)
NECK_BELOW_HEAD = 0.10
#: bones: (VRM humanoid name, parent name or None, world position at rest in metres).
BONES = (
    ("hips", None, (0.0, 0.95, 0.0)),
    ("spine", "hips", (0.0, 1.05, 0.0)),
    ("chest", "spine", (0.0, 1.17, 0.0)),
    ("neck", "chest", (0.0, HEAD_HEIGHT - NECK_BELOW_HEAD, 0.0)),
    ("head", "neck", (0.0, HEAD_HEIGHT, 0.0)),
    ("leftUpperArm", "chest", (0.18, 1.33, 0.0)),
    ("leftLowerArm", "leftUpperArm", (0.46, 1.33, 0.0)),
    ("leftHand", "leftLowerArm", (0.72, 1.33, 0.0)),
    ("rightUpperArm", "chest", (-0.18, 1.33, 0.0)),
    ("rightLowerArm", "rightUpperArm", (-0.46, 1.33, 0.0)),
    ("rightHand", "rightLowerArm", (-0.72, 1.33, 0.0)),
    ("leftUpperLeg", "hips", (0.09, 0.90, 0.0)),
    ("leftLowerLeg", "leftUpperLeg", (0.09, 0.50, 0.0)),
    ("leftFoot", "leftLowerLeg", (0.09, 0.08, 0.0)),
    ("rightUpperLeg", "hips", (-0.09, 0.90, 0.0)),
    ("rightLowerLeg", "rightUpperLeg", (-0.09, 0.50, 0.0)),
    ("rightFoot", "rightLowerLeg", (-0.09, 0.08, 0.0)),
)
#: the humanoid bones VRM 1.0 requires (``humanoid.md``)
REQUIRED_BONES = frozenset({"hips", "spine", "head", "leftUpperArm", "leftLowerArm", "leftHand",
                            "rightUpperArm", "rightLowerArm", "rightHand", "leftUpperLeg", "leftLowerLeg",
                            "leftFoot", "rightUpperLeg", "rightLowerLeg", "rightFoot"})
VRM_EXTENSION = "VRMC_vrm"

_FLOAT, _USHORT, _UBYTE, _UINT = 5126, 5123, 5121, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


def skin_weights(head_weight: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """JOINTS_0 (indices into :data:`BONES`) and WEIGHTS_0 for vertices' head weights (module
    docstring): ``(N, 4)`` uint8 and ``(N, 4)`` float32, each row summing to 1."""
    names = [b[0] for b in BONES]
    chest, neck, head = names.index("chest"), names.index("neck"), names.index("head")
    w = np.clip(np.asarray(head_weight, dtype=np.float64), 0.0, 1.0)
    n = len(w)
    joints = np.zeros((n, 4), np.uint8)
    weights = np.zeros((n, 4), np.float32)
    low = w <= 0.5
    joints[low, 0], joints[low, 1] = chest, neck
    weights[low, 0], weights[low, 1] = 1.0 - 2.0 * w[low], 2.0 * w[low]
    joints[~low, 0], joints[~low, 1] = neck, head
    weights[~low, 0], weights[~low, 1] = 2.0 - 2.0 * w[~low], 2.0 * w[~low] - 1.0
    return joints, weights


def _srgb_to_linear(c: np.ndarray) -> np.ndarray:
    c = np.clip(np.asarray(c, dtype=np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _check_mesh(positions, normals, colors, head_weight, indices):
    pos = np.asarray(positions, dtype=np.float32)
    if pos.ndim != 2 or pos.shape[1] != 3 or len(pos) == 0:
        raise ParameterError(f"positions must be (N, 3) with N > 0; got shape {pos.shape}")
    n = len(pos)
    nrm, col = np.asarray(normals, dtype=np.float32), np.asarray(colors, dtype=np.float64)
    w = np.asarray(head_weight, dtype=np.float64)
    idx = np.asarray(indices)
    for name, arr, shape in (("normals", nrm, (n, 3)), ("colors", col, (n, 3)), ("head_weight", w, (n,))):
        if arr.shape != shape:
            raise ParameterError(f"{name} must have shape {shape}; got {arr.shape}")
    if idx.ndim != 2 or idx.shape[1] != 3 or len(idx) == 0 or idx.min() < 0 or idx.max() >= n:
        raise ParameterError(f"indices must be (M, 3) triangles of vertices 0..{n - 1}")
    if not (np.isfinite(pos).all() and np.isfinite(nrm).all() and np.isfinite(w).all()):
        raise ParameterError("the mesh holds NaN or infinite values")
    return pos, nrm, col, w, idx


def build_vrm(positions, normals, colors, head_weight, indices, *, name: str = "headmotion bust",
              neck_share: float | None = None, extras: dict | None = None):
    """The VRM 1.0 document (a ``pygltflib.GLTF2`` with its binary blob) of a bust mesh.

    Parameters
    ----------
    positions, normals : (N, 3) metres and unit normals, in the head frame (origin at the top of
        the neck, the head bone; +x the model's left, +y up, +z forward)
    colors : (N, 3) sRGB in [0, 1] (written as linear ``COLOR_0``)
    head_weight : (N,) 1 moves with the head, 0 with the chest
    indices : (M, 3) triangles, counter-clockwise seen from outside
    name : the avatar's name in the VRM metadata
    neck_share : float in [0, 1], stored for players (default the BVH writer's)
    extras : more entries for ``asset.extras`` (e.g. how the mesh was made)
    """
    from .bvh import DEFAULT_NECK_SHARE

    g = _gltf()
    s = DEFAULT_NECK_SHARE if neck_share is None else float(neck_share)
    if not 0.0 <= s <= 1.0:
        raise ParameterError(f"neck_share must be in [0, 1]; got {neck_share!r}")
    pos, nrm, col, w, idx = _check_mesh(positions, normals, colors, head_weight, indices)
    pos = pos + np.array([0.0, HEAD_HEIGHT, 0.0], np.float32)
    blob = bytearray()
    views, accessors = [], []

    def add(arr, kind, ctype, *, target=None, minmax=False, normalized=False) -> int:
        arr = np.ascontiguousarray(arr)
        while len(blob) % 4:
            blob.append(0)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=arr.nbytes, target=target))
        blob.extend(arr.tobytes())
        acc = g.Accessor(bufferView=len(views) - 1, componentType=ctype, count=int(arr.shape[0]), type=kind,
                         normalized=normalized or None)
        if minmax:
            flat = arr.reshape(arr.shape[0], -1)
            acc.min = [float(x) for x in flat.min(axis=0)]
            acc.max = [float(x) for x in flat.max(axis=0)]
        accessors.append(acc)
        return len(accessors) - 1

    joints, weights = skin_weights(w)
    rgba = np.concatenate([np.round(_srgb_to_linear(col) * 255), np.full((len(col), 1), 255)], axis=1)
    attrs = g.Attributes(
        POSITION=add(pos, "VEC3", _FLOAT, target=_ARRAY_BUFFER, minmax=True),
        NORMAL=add(nrm, "VEC3", _FLOAT, target=_ARRAY_BUFFER),
        COLOR_0=add(rgba.astype(np.uint8), "VEC4", _UBYTE, target=_ARRAY_BUFFER, normalized=True),
        JOINTS_0=add(joints, "VEC4", _UBYTE, target=_ARRAY_BUFFER),
        WEIGHTS_0=add(weights, "VEC4", _FLOAT, target=_ARRAY_BUFFER))
    big = len(pos) > 65535
    a_idx = add(idx.astype(np.uint32 if big else np.uint16).ravel(), "SCALAR", _UINT if big else _USHORT,
                target=_ELEMENT_ARRAY_BUFFER, minmax=True)
    names = [b[0] for b in BONES]
    world = np.array([b[2] for b in BONES], dtype=np.float64)
    ibm = np.tile(np.eye(4, dtype=np.float32), (len(BONES), 1, 1))
    ibm[:, :3, 3] = -world
    a_ibm = add(np.transpose(ibm, (0, 2, 1)).reshape(len(BONES), 16), "MAT4", _FLOAT)  # column-major

    nodes = []
    for k, (bone, parent, _) in enumerate(BONES):
        local = world[k] - (world[names.index(parent)] if parent else 0.0)
        nodes.append(g.Node(name=bone, translation=[round(float(x), 6) for x in local],
                            children=[j for j, b in enumerate(BONES) if b[1] == bone]))
    nodes.append(g.Node(name="bust", mesh=0, skin=0))
    vrm = {
        "specVersion": "1.0",
        "meta": {"name": name, "version": "1", "authors": ["the headmotion authors"],
                 "copyrightInformation": "made in code by headmotion (MIT licence)",
                 "licenseUrl": "https://vrm.dev/licenses/1.0/", "avatarPermission": "everyone",
                 "allowExcessivelyViolentUsage": False, "allowExcessivelySexualUsage": False,
                 "commercialUsage": "corporation", "allowPoliticalOrReligiousUsage": True,
                 "allowAntisocialOrHateUsage": False, "creditNotation": "unnecessary",
                 "allowRedistribution": True, "modification": "allowModificationRedistribution",
                 "otherLicenseUrl": "https://opensource.org/license/mit"},
        "humanoid": {"humanBones": {bone: {"node": k} for k, (bone, _, _) in enumerate(BONES)}},
    }
    doc = g.GLTF2(
        asset=g.Asset(version="2.0", generator="headmotion.io.vrm",
                      extras={"neck_share": s, "axes": "+Y up, +Z forward, +X the model's left", **(extras or {})}),
        extensionsUsed=[VRM_EXTENSION],
        extensions={VRM_EXTENSION: vrm},
        scene=0,
        scenes=[g.Scene(name=name, nodes=[0, len(BONES)])],
        nodes=nodes,
        meshes=[g.Mesh(name="bust", primitives=[g.Primitive(attributes=attrs, indices=a_idx, material=0)])],
        materials=[g.Material(name="vertex colours", pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=0.0, roughnessFactor=0.75))],
        skins=[g.Skin(name="humanoid", joints=list(range(len(BONES))), skeleton=0, inverseBindMatrices=a_ibm)],
        accessors=accessors,
        bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob))],
    )
    doc.set_binary_blob(bytes(blob))
    return doc


def vrm_bytes(*args, **kwargs) -> bytes:
    """:func:`build_vrm` as the bytes of a ``.vrm`` file (binary glTF)."""
    return b"".join(build_vrm(*args, **kwargs).save_to_bytes())


def save_vrm(path, *args, **kwargs) -> None:
    """Write :func:`build_vrm`'s avatar to ``path`` (``.vrm``, binary glTF; written atomically)."""
    p = Path(path)
    if p.suffix.lower() != ".vrm":
        raise FormatError(f"a VRM file must end in .vrm; got {p.suffix or '(none)'!r}", path=p)
    data = vrm_bytes(*args, **kwargs)
    with atomic_open(p, "wb") as fh:
        fh.write(data)


__all__ = ["build_vrm", "save_vrm", "vrm_bytes", "skin_weights", "BONES", "REQUIRED_BONES", "HEAD_HEIGHT",
           "NECK_BELOW_HEAD", "VRM_EXTENSION"]
