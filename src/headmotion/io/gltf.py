"""glTF 2.0 export: head motion as an animation of a minimal humanoid's neck and head.
The seeds are silent on file formats beyond BVH (thesis §2.2.3); glTF is what web
engines (three.js, Babylon), game engines and Blender import, and VRM avatars are glTF.

What is written
---------------
A skeleton named with the VRM humanoid bone names — ``hips → spine → chest → neck → head`` — as
glTF nodes (rest rotations identity, translations in metres: hips 0.95 m above the floor, spine
+0.10, chest +0.20, neck +0.25, head +0.10), a small skinned mesh (torso, neck and a head with a
nose, boxes in the project's grey) bound to them through a skin (so importers that only make
armatures from skins, like Blender's, see bones), and one animation, ``headmotion``, with two
rotation channels (``neck`` and ``head``), LINEAR interpolation (slerp in glTF), one keyframe per
motion frame at ``t = i / fps`` seconds.  The motion's frame rate is also stored in the
animation's ``extras.fps``.

Neck and head share the rotation as in the BVH export (:func:`headmotion.io.bvh.save_bvh`): the
neck holds ``exp(s·r)``, the head ``exp(s·r)⁻¹ exp(r)``, so their composition is the motion; the
default ``s`` is :data:`headmotion.io.bvh.DEFAULT_NECK_SHARE` (0.93, measured on mocap).

Axes: glTF is right-handed, **+Y up, the model faces +Z**, hence **+X is the model's left** —
exactly our convention (:mod:`headmotion.rotations`: +x left, +y up, +z forward).  The mapping is
the identity: a rotation vector ``r`` becomes the unit quaternion of ``r`` in glTF's ``(x, y, z,
w)`` order.  Consecutive quaternions are kept in the same hemisphere (q and −q are the same
rotation; interpolating across a sign flip would spin the long way round).  Values are float32
(glTF's only float type), about 1e-7 rad of rounding.

Extensions: ``.glb`` (binary, one file) or ``.gltf`` (JSON with the buffer embedded as a base64
data URI, still one file).  ``Motion.translation`` is not written.

Libraries considered: pygltflib (maintained, MIT) builds and serialises the glTF structure and is
used here; trimesh exports meshes but no skins or animations.  The vertex and keyframe buffers
are packed with numpy.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import FormatError, MissingDependencyError, ParameterError
from ..types import Motion
from .atomic import atomic_open

#: VRM humanoid bone names, parent first, and each bone's offset from its parent (m, +Y up).
SKELETON = (
    ("hips", (0.0, 0.95, 0.0)),
    ("spine", (0.0, 0.10, 0.0)),
    ("chest", (0.0, 0.20, 0.0)),
    ("neck", (0.0, 0.25, 0.0)),
    ("head", (0.0, 0.10, 0.0)),
)
ANIMATION_NAME = "headmotion"

# glTF constants
_FLOAT, _USHORT, _UBYTE = 5126, 5123, 5121
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


def _gltf():
    try:
        import pygltflib
    except ImportError as exc:  # pragma: no cover - a dependency
        raise MissingDependencyError(f"glTF output needs pygltflib (pip install pygltflib): {exc}") from exc
    return pygltflib


def _box(lo, hi):
    """8 corners and 12 outward-facing triangles (counter-clockwise) of an axis-aligned box."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    v = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                  [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]], dtype=np.float32)
    f = np.array([[0, 2, 1], [0, 3, 2],   # -z
                  [4, 5, 6], [4, 6, 7],   # +z
                  [0, 1, 5], [0, 5, 4],   # -y
                  [3, 7, 6], [3, 6, 2],   # +y
                  [0, 4, 7], [0, 7, 3],   # -x
                  [1, 2, 6], [1, 6, 5]],  # +x
                 dtype=np.uint16)
    return v, f


def _rest_positions() -> np.ndarray:
    return np.cumsum(np.array([off for _, off in SKELETON], dtype=float), axis=0)


def _body_mesh():
    """Positions, joint indices, weights and triangle indices of the boxes, bound rigidly."""
    pos = _rest_positions()
    neck, head = pos[3], pos[4]
    parts = [  # (lo, hi, joint index in SKELETON)
        ((-0.18, pos[1][1], -0.10), (0.18, neck[1] + 0.01, 0.10), 2),
        ((-0.05, neck[1] - 0.01, -0.05), (0.05, head[1] + 0.02, 0.05), 3),
        ((-0.09, head[1] - 0.01, -0.10), (0.09, head[1] + 0.23, 0.11), 4),
        ((-0.015, head[1] + 0.07, 0.11), (0.015, head[1] + 0.11, 0.15), 4),  # the nose: +Z is forward
    ]
    vs, fs, js = [], [], []
    n = 0
    for lo, hi, j in parts:
        v, f = _box(lo, hi)
        vs.append(v)
        fs.append(f + n)
        js.append(np.full(len(v), j))
        n += len(v)
    v = np.concatenate(vs)
    joints = np.zeros((n, 4), np.uint8)
    joints[:, 0] = np.concatenate(js)
    weights = np.zeros((n, 4), np.float32)
    weights[:, 0] = 1.0
    return v, joints, weights, np.concatenate(fs).ravel()


def _continuous(q: np.ndarray) -> np.ndarray:
    """Flip signs so each quaternion is in the hemisphere of the previous one."""
    q = q.copy()
    for i in range(1, len(q)):
        if np.dot(q[i], q[i - 1]) < 0:
            q[i] = -q[i]
    return q


def neck_head_rotations(motion: Motion, neck_share: float) -> tuple[Rotation, Rotation]:
    """The neck's and the head's local rotations: ``exp(s·r)`` and ``exp(s·r)⁻¹ exp(r)``."""
    rv = np.array(motion.rotvec, dtype=float)
    neck = Rotation.from_rotvec(neck_share * rv)
    return neck, neck.inv() * Rotation.from_rotvec(rv)


def build_gltf(motion: Motion, *, neck_share: float | None = None):
    """The glTF document (a ``pygltflib.GLTF2`` with its binary blob set) for ``motion``."""
    from .bvh import DEFAULT_NECK_SHARE

    g = _gltf()
    if not isinstance(motion, Motion):
        raise ParameterError(f"save_gltf needs a Motion; got {type(motion).__name__}")
    if len(motion) == 0:
        raise ParameterError("cannot write a glTF animation with zero frames")
    s = DEFAULT_NECK_SHARE if neck_share is None else float(neck_share)
    if not 0.0 <= s <= 1.0:
        raise ParameterError(f"neck_share must be in [0, 1]; got {neck_share!r}")

    blob = bytearray()
    views, accessors = [], []

    def add(arr: np.ndarray, kind: str, ctype: int, *, target=None, minmax=False, normalized=False) -> int:
        arr = np.ascontiguousarray(arr)
        while len(blob) % 4:
            blob.append(0)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=arr.nbytes, target=target))
        blob.extend(arr.tobytes())
        count = arr.shape[0]
        acc = g.Accessor(bufferView=len(views) - 1, componentType=ctype, count=int(count), type=kind,
                         normalized=normalized or None)
        if minmax:
            flat = arr.reshape(count, -1)
            acc.min = [float(x) for x in flat.min(axis=0)]
            acc.max = [float(x) for x in flat.max(axis=0)]
        accessors.append(acc)
        return len(accessors) - 1

    # mesh and skin
    v, joints, weights, idx = _body_mesh()
    a_pos = add(v, "VEC3", _FLOAT, target=_ARRAY_BUFFER, minmax=True)
    a_jnt = add(joints, "VEC4", _UBYTE, target=_ARRAY_BUFFER)
    a_wgt = add(weights, "VEC4", _FLOAT, target=_ARRAY_BUFFER)
    a_idx = add(idx.astype(np.uint16), "SCALAR", _USHORT, target=_ELEMENT_ARRAY_BUFFER, minmax=True)
    rest = _rest_positions()
    ibm = np.tile(np.eye(4, dtype=np.float32), (len(SKELETON), 1, 1))
    ibm[:, :3, 3] = -rest
    a_ibm = add(np.transpose(ibm, (0, 2, 1)).reshape(len(SKELETON), 16), "MAT4", _FLOAT)  # column-major
    # animation
    times = (np.arange(len(motion), dtype=np.float64) / motion.fps).astype(np.float32)
    neck, head = neck_head_rotations(motion, s)
    a_t = add(times, "SCALAR", _FLOAT, minmax=True)
    a_qn = add(_continuous(neck.as_quat()).astype(np.float32), "VEC4", _FLOAT)  # scipy: (x, y, z, w)
    a_qh = add(_continuous(head.as_quat()).astype(np.float32), "VEC4", _FLOAT)

    nodes = []
    for k, (name, off) in enumerate(SKELETON):
        nodes.append(g.Node(name=name, translation=[float(x) for x in off],
                            children=[k + 1] if k + 1 < len(SKELETON) else []))
    nodes.append(g.Node(name="body", mesh=0, skin=0))
    i_neck, i_head = 3, 4
    doc = g.GLTF2(
        asset=g.Asset(version="2.0", generator="headmotion"),
        scene=0,
        scenes=[g.Scene(name="headmotion", nodes=[0, len(SKELETON)])],
        nodes=nodes,
        meshes=[g.Mesh(name="body", primitives=[g.Primitive(
            attributes=g.Attributes(POSITION=a_pos, JOINTS_0=a_jnt, WEIGHTS_0=a_wgt), indices=a_idx, material=0)])],
        materials=[g.Material(name="grey", pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=[0.72, 0.72, 0.70, 1.0], metallicFactor=0.0, roughnessFactor=0.8))],
        skins=[g.Skin(name="humanoid", joints=list(range(len(SKELETON))), skeleton=0, inverseBindMatrices=a_ibm)],
        animations=[g.Animation(
            name=ANIMATION_NAME,
            samplers=[g.AnimationSampler(input=a_t, output=a_qn, interpolation="LINEAR"),
                      g.AnimationSampler(input=a_t, output=a_qh, interpolation="LINEAR")],
            channels=[g.AnimationChannel(sampler=0, target=g.AnimationChannelTarget(node=i_neck, path="rotation")),
                      g.AnimationChannel(sampler=1, target=g.AnimationChannelTarget(node=i_head, path="rotation"))],
            extras={"fps": float(motion.fps), "neck_share": s,
                    "convention": "+Y up, +Z forward, +X the model's left (headmotion's axes)"})],
        accessors=accessors,
        bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob))],
    )
    doc.set_binary_blob(bytes(blob))
    return doc


def save_gltf(motion: Motion, path, *, neck_share: float | None = None) -> None:
    """Write ``motion`` as glTF 2.0: ``.glb`` (binary) or ``.gltf`` (JSON, buffer embedded).

    Parameters
    ----------
    motion : Motion
    path : str or Path, ending in ``.glb`` or ``.gltf`` (written atomically)
    neck_share : float in [0, 1], share of the rotation on the neck bone (default
        :data:`headmotion.io.bvh.DEFAULT_NECK_SHARE`)
    """
    p = Path(path)
    ext = p.suffix.lower()
    if ext not in (".glb", ".gltf"):
        raise FormatError(f"a glTF file must end in .glb or .gltf; got {ext or '(none)'!r}", path=p)
    doc = build_gltf(motion, neck_share=neck_share)
    if ext == ".glb":
        data = b"".join(doc.save_to_bytes())
        with atomic_open(p, "wb") as fh:
            fh.write(data)
    else:
        blob = doc.binary_blob()
        doc.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(blob).decode("ascii")
        doc.destroy_binary_blob()
        text = doc.gltf_to_json()
        with atomic_open(p, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)


def _accessor_array(doc, index: int, blob: bytes) -> np.ndarray:
    acc = doc.accessors[index]
    view = doc.bufferViews[acc.bufferView]
    n_comp = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc.type]
    dtype = {_FLOAT: np.float32, _USHORT: np.uint16, _UBYTE: np.uint8}[acc.componentType]
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    arr = np.frombuffer(blob, dtype=dtype, count=acc.count * n_comp, offset=start)
    return arr.reshape(acc.count, n_comp) if n_comp > 1 else arr


def load_gltf(path) -> Motion:
    """Read back a file written by :func:`save_gltf`: the head's rotation relative to the chest
    (neck ∘ head) at the keyframes, at ``extras.fps`` (or the keyframes' median rate)."""
    g = _gltf()
    p = Path(path)
    try:
        doc = g.GLTF2().load(str(p))
    except (OSError, ValueError, json.JSONDecodeError) as exc:
        raise FormatError(f"not a readable glTF file ({exc})", path=p) from None
    if doc is None or not doc.animations:
        raise FormatError("glTF file holds no animation", path=p)
    if p.suffix.lower() == ".gltf":
        uri = doc.buffers[0].uri or ""
        if not uri.startswith("data:"):
            raise FormatError("only .gltf files with an embedded (data URI) buffer are read", path=p)
        blob = base64.b64decode(uri.split(",", 1)[1])
    else:
        blob = doc.binary_blob()
    names = [n.name for n in doc.nodes]
    anim = doc.animations[0]
    tracks = {}
    times = None
    for ch in anim.channels:
        if ch.target.path != "rotation":
            continue
        smp = anim.samplers[ch.sampler]
        tracks[names[ch.target.node]] = _accessor_array(doc, smp.output, blob).astype(float)
        times = _accessor_array(doc, smp.input, blob).astype(float)
    if "head" not in tracks:
        raise FormatError(f"glTF animation has no rotation channel on a node named 'head'; nodes: {names}", path=p)
    rot = Rotation.from_quat(tracks["head"])
    if "neck" in tracks:
        rot = Rotation.from_quat(tracks["neck"]) * rot
    extras = anim.extras or {}
    fps = float(extras.get("fps") or (1.0 / np.median(np.diff(times)) if len(times) > 1 else 30.0))
    return Motion(rot.as_rotvec(), fps, meta={"source": str(p), "format": "gltf"})


__all__ = ["save_gltf", "load_gltf", "build_gltf", "neck_head_rotations", "SKELETON", "ANIMATION_NAME"]
