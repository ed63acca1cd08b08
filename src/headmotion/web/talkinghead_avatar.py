"""The TalkingHead page's avatar: a full-body figure with the Ready Player Me skeleton
(:mod:`headmotion.io.rpm`) whose head is the project's head model.

* ``Face`` and ``HeadNeck`` — the head, ears and neck of :func:`headmotion.render.mesh.build_head_mesh`
  (detail 0), skinned to ``Spine2``, ``Neck`` and ``Head`` by the mesh's head weights as the VRM
  bust is (:func:`headmotion.io.vrm.skin_weights`), with the lips cut apart between the mouth's
  corners and a mouth behind them (teeth, tongue), split in two (:func:`split_moving`): ``Face``,
  the part the face's morph targets move, carries them — every ARKit
  blendshape but the eyes', the 15 visemes and ``mouthOpen``/``mouthSmile``, made from a few
  movements (:func:`face_morphs`: the jaw turning open about its hinge, the lips and the corners
  of the mouth, brows, cheeks and nose moving under smooth bumps) — and ``HeadNeck`` is the rest
  (a browser drawing without a GPU morphs three times fewer vertices);
* ``EyeLeft``, ``EyeRight`` — the VRM bust's eye spheres (:func:`headmotion.web.build_assets.eyes`)
  skinned to the eye bones, with the eyes' blendshapes: looking up, down, in and out turns the
  eyeball by :data:`LOOK_RAD`; a blink, squint or wide eye flattens or stretches it vertically
  (the eyes have no lids);
* ``Body`` — a torso lofted from hips to shoulders and capsules for the arms, the hands (mittens),
  the legs and the feet, each rigid on its bone (the torso blended up the spine), standing on the
  floor in the T-pose of :data:`headmotion.io.rpm.BONES`.
"""

from __future__ import annotations

import numpy as np

from ..io.rpm import ARKIT_BLENDSHAPES, BONES, MIN_MOVE, SkinnedPart, bone_index
from ..render.mesh import HEAD_CENTER, build_head_mesh

#: where the head model's origin (the top of the neck) stands: the Head bone
HEAD_AT = np.array(dict((b[0], b[2]) for b in BONES)["Head"], float)
#: the mouth line (relative to HEAD_CENTER, m), the half-width of the cut and of the mouth
MOUTH_Y, CUT_HALF, MOUTH_HALF = -0.056, 0.020, 0.023
#: the jaw's hinge (relative to HEAD_CENTER) and how far jawOpen turns it (rad)
JAW_PIVOT, JAW_RAD = np.array([0.0, -0.010, -0.012]), 0.28
#: how far the eyes' look blendshapes turn the eyeballs (rad)
LOOK_RAD = 0.35
SKIN, CLOTH = (0.86, 0.66, 0.55), (0.20, 0.27, 0.38)
TROUSERS, SHOES = (0.17, 0.18, 0.21), (0.10, 0.08, 0.07)


def _smooth(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def _bump(p, c, s):
    """A smooth bump (1 at ``c``, falling off over the radii ``s``)."""
    return np.exp(-np.sum(((p - np.asarray(c)) / np.asarray(s)) ** 2, axis=-1))


def _rotation(axis: str, angle: float) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler(axis, angle).as_matrix()


def _turn(p, pivot, axis, angle, w):
    """Displacement of turning ``p`` about ``pivot`` by ``angle``, scaled by the weights ``w``."""
    q = (p - pivot) @ _rotation(axis, angle).T + pivot
    return (q - p) * np.asarray(w)[:, None]


def _normals(pos, idx):
    n = np.zeros_like(pos)
    fn = np.cross(pos[idx[:, 1]] - pos[idx[:, 0]], pos[idx[:, 2]] - pos[idx[:, 0]])
    for k in range(3):
        np.add.at(n, idx[:, k], fn)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def _grid(ring, n_around):
    """Triangles joining consecutive rings of ``n_around`` vertices (``ring`` rings)."""
    tris = []
    for i in range(ring - 1):
        for j in range(n_around):
            a, b = i * n_around + j, i * n_around + (j + 1) % n_around
            tris += [(a, b, a + n_around), (b, b + n_around, a + n_around)]
    return np.asarray(tris, np.int64)


def _outward(pos, idx, centre_of):
    """Flip triangles to face away from ``centre_of(triangle centroids)``."""
    c = pos[idx].mean(axis=1)
    n = np.cross(pos[idx[:, 1]] - pos[idx[:, 0]], pos[idx[:, 2]] - pos[idx[:, 0]])
    flip = np.sum(n * (c - centre_of(c)), axis=1) < 0
    idx = idx.copy()
    idx[flip] = idx[flip][:, [0, 2, 1]]
    return idx


def capsule(a, b, r, *, n_around=16, n_cap=5, flatten=1.0, flat_axis=(0.0, 1.0, 0.0)):
    """Positions and triangles of a capsule from ``a`` to ``b`` of radius ``r`` (squashed to
    ``flatten`` of it along ``flat_axis``)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ax = (b - a) / np.linalg.norm(b - a)
    u = np.cross(ax, [0.0, 0.0, 1.0] if abs(ax[2]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(ax, u)
    th = np.concatenate([np.linspace(0, np.pi / 2, n_cap), np.linspace(np.pi / 2, np.pi, n_cap)])
    ph = np.linspace(0, 2 * np.pi, n_around, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    ends = np.where(np.arange(2 * n_cap) < n_cap, 1, 0)[:, None, None]
    d = np.cos(T)[..., None] * ax + np.sin(T)[..., None] * (np.cos(P)[..., None] * u + np.sin(P)[..., None] * v)
    pos = (ends * b + (1 - ends) * a) + r * d
    pos = pos.reshape(-1, 3)
    f = np.asarray(flat_axis, float)
    centre = a + np.outer(np.clip((pos - a) @ ax, 0, np.linalg.norm(b - a)), ax)
    off = pos - centre
    pos = centre + off - (1 - flatten) * np.outer(off @ f, f)
    idx = _grid(2 * n_cap, n_around)
    return pos, _outward(pos, idx, lambda c: a + np.outer(np.clip((c - a) @ ax, 0, np.linalg.norm(b - a)), ax))


def torso(n_around=32):
    """A torso lofted through elliptic rings from below the hips to the shoulders, closed at both
    ends: positions and triangles."""
    y = np.array([0.84, 0.90, 1.00, 1.10, 1.20, 1.30, 1.38, 1.44, 1.48])
    hx = np.array([0.12, 0.165, 0.160, 0.145, 0.150, 0.172, 0.190, 0.185, 0.110])
    hz = np.array([0.09, 0.110, 0.105, 0.100, 0.105, 0.115, 0.110, 0.090, 0.060])
    a = np.linspace(-np.pi, np.pi, n_around, endpoint=False)
    s, c = np.sin(a), np.cos(a)
    e = 0.7  # superellipse: squarer than an ellipse
    rings = np.stack([np.stack([hx[i] * np.sign(s) * np.abs(s) ** e, np.full_like(a, y[i]),
                                hz[i] * np.sign(c) * np.abs(c) ** e], -1) for i in range(len(y))])
    pos = np.vstack([rings.reshape(-1, 3), [[0, y[0] - 0.03, 0], [0, y[-1] + 0.01, 0]]])
    idx = [*_grid(len(y), n_around)]
    bottom, top, last = len(pos) - 2, len(pos) - 1, (len(y) - 1) * n_around
    for j in range(n_around):
        idx += [(bottom, (j + 1) % n_around, j), (top, last + j, last + (j + 1) % n_around)]
    idx = np.asarray(idx, np.int64)
    return pos, _outward(pos, idx, lambda ctr: np.c_[np.zeros(len(ctr)), ctr[:, 1], np.zeros(len(ctr))])


def _rigid(n, bone):
    j = np.zeros((n, 4), np.uint8)
    j[:, 0] = bone_index(bone)
    w = np.zeros((n, 4), np.float32)
    w[:, 0] = 1.0
    return j, w


def body() -> SkinnedPart:
    """The ``Body`` mesh (module docstring)."""
    pos, idx = torso()
    heights = [("Hips", 1.00), ("Spine", 1.10), ("Spine1", 1.22), ("Spine2", 1.35)]
    joints = np.zeros((len(pos), 4), np.uint8)
    weights = np.zeros((len(pos), 4), np.float32)
    hs = np.array([h for _, h in heights])
    k = np.clip(np.searchsorted(hs, pos[:, 1]) - 1, 0, len(hs) - 2)
    t = np.clip((pos[:, 1] - hs[k]) / (hs[k + 1] - hs[k]), 0, 1)
    names = np.array([bone_index(n) for n, _ in heights])
    joints[:, 0], joints[:, 1] = names[k], names[k + 1]
    weights[:, 0], weights[:, 1] = 1 - t, t
    cols = [np.tile(CLOTH, (len(pos), 1))]
    parts_pos, parts_idx, parts_j, parts_w = [pos], [idx], [joints], [weights]
    at = {b[0]: np.asarray(b[2], float) for b in BONES}
    for side in ("Left", "Right"):
        sx = 1.0 if side == "Left" else -1.0
        hand_end = at[f"{side}Hand"] + [sx * 0.16, 0, 0]
        foot = at[f"{side}Foot"]
        pieces = [  # (from, to, radius, bone, colour, flatten)
            (at[f"{side}Arm"], at[f"{side}ForeArm"], 0.046, f"{side}Arm", CLOTH, 1.0),
            (at[f"{side}ForeArm"], at[f"{side}Hand"], 0.037, f"{side}ForeArm", SKIN, 1.0),
            (at[f"{side}Hand"] + [sx * 0.03, 0, 0], hand_end, 0.042, f"{side}Hand", SKIN, 0.45),
            (at[f"{side}UpLeg"], at[f"{side}Leg"], 0.075, f"{side}UpLeg", TROUSERS, 1.0),
            (at[f"{side}Leg"], foot + [0, 0.02, 0], 0.052, f"{side}Leg", TROUSERS, 1.0),
            ([foot[0], 0.04, -0.05], [foot[0], 0.04, 0.12], 0.04, f"{side}Foot", SHOES, 1.0),
            ([foot[0], 0.03, 0.12], [foot[0], 0.03, 0.20], 0.03, f"{side}ToeBase", SHOES, 1.0),
        ]
        for a, b, r, bone, col, flat in pieces:
            p, i = capsule(a, b, r, flatten=flat)
            j, w = _rigid(len(p), bone)
            parts_idx.append(i + sum(len(q) for q in parts_pos))
            parts_pos.append(p)
            parts_j.append(j)
            parts_w.append(w)
            cols.append(np.tile(col, (len(p), 1)))
    pos, idx = np.vstack(parts_pos), np.vstack(parts_idx)
    return SkinnedPart("Body", pos, _normals(pos, idx), np.vstack(cols), np.vstack(parts_j), np.vstack(parts_w), idx)


def _head_joints(head_weight):
    """Spine2/Neck/Head joints and weights for head weights: the VRM bust's split along the neck
    (:func:`headmotion.io.vrm.skin_weights`) on this skeleton's chest, neck and head."""
    from ..io.vrm import BONES as VRM_BONES, skin_weights

    joints, weights = skin_weights(head_weight)
    names = [b[0] for b in VRM_BONES]
    ours = np.zeros(len(names), np.uint8)
    for vrm, rpm in (("chest", "Spine2"), ("neck", "Neck"), ("head", "Head")):
        ours[names.index(vrm)] = bone_index(rpm)
    return ours[joints], weights


def cut_lips(pos, idx):
    """Cut the face apart along the mouth line between the corners: the vertices shared by
    triangles above and below it within :data:`CUT_HALF` are doubled, the copies taken by the
    triangles below.  ``pos`` relative to HEAD_CENTER.  Returns the positions, the triangles and
    each vertex's original (its own index, or the one it copies)."""
    c = pos[idx].mean(axis=1)
    near = (np.abs(c[:, 0]) < MOUTH_HALF + 0.004) & (c[:, 2] > 0.06) & (np.abs(c[:, 1] - MOUTH_Y) < 0.02)
    upper, lower = near & (c[:, 1] > MOUTH_Y), near & (c[:, 1] <= MOUTH_Y)
    shared = np.intersect1d(idx[upper].ravel(), idx[lower].ravel())
    shared = shared[np.abs(pos[shared, 0]) < CUT_HALF]
    copy = {int(v): len(pos) + k for k, v in enumerate(shared)}
    idx = idx.copy()
    for t in np.flatnonzero(lower):
        idx[t] = [copy.get(int(v), int(v)) for v in idx[t]]
    return np.vstack([pos, pos[shared]]), idx, np.r_[np.arange(len(pos)), shared]


def mouth(n_around=16, n_down=10):
    """The inside of the mouth (relative to HEAD_CENTER): an ellipsoid behind the lips, dark with
    white teeth at the front and a tongue below.  Positions, sRGB colours, triangles."""
    th = np.linspace(0.15, np.pi - 0.15, n_down)
    ph = np.linspace(-np.pi, np.pi, n_around, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    d = np.stack([np.sin(T) * np.sin(P), np.cos(T), np.sin(T) * np.cos(P)], -1).reshape(-1, 3)
    centre, radii = np.array([0.0, MOUTH_Y - 0.002, 0.068]), np.array([0.017, 0.012, 0.012])
    pos = centre + d * radii
    front = d[:, 2] > 0.45
    col = np.where((front & (np.abs(d[:, 1]) > 0.35))[:, None], [0.93, 0.91, 0.86],
                   np.where((d[:, 1] < -0.2)[:, None], [0.72, 0.36, 0.36], [0.30, 0.07, 0.08]))
    idx = _grid(n_down, n_around)
    return pos, col, _outward(pos, idx, lambda c: np.broadcast_to(centre, c.shape))


def _subset(part: SkinnedPart, tris, name: str, morphs: bool) -> SkinnedPart:
    used = np.unique(part.indices[tris])
    new = np.full(len(part.positions), -1)
    new[used] = np.arange(len(used))
    m = {k: (None if d is None else d[used]) for k, d in part.morphs.items()} if morphs else {}
    return SkinnedPart(name, part.positions[used], part.normals[used], part.colors[used], part.joints[used],
                       part.weights[used], new[part.indices[tris]], m)


def split_moving(part: SkinnedPart, rest_name: str) -> list[SkinnedPart]:
    """``part`` as two meshes: the triangles some morph target moves (with the morph targets) and
    the others (``rest_name``, without): a renderer then morphs only the vertices that move.  The
    vertices the two share move in no target, so the seam stays closed."""
    moves = np.zeros(len(part.positions), bool)
    for d in part.morphs.values():
        if d is not None:
            moves |= np.linalg.norm(d, axis=1) >= MIN_MOVE
    tris = moves[part.indices].any(axis=1)
    return [_subset(part, tris, part.name, True), _subset(part, ~tris, rest_name, False)]


def face_morphs(p, below, in_mouth):
    """The face's blendshapes: displacements (m) of the points ``p`` (relative to HEAD_CENTER;
    ``below``: on the jaw's side of the mouth line, the lower lip's copies on the cut included;
    ``in_mouth``: the mouth's inside)."""
    x, y = p[:, 0], p[:, 1]
    lens = np.clip(1 - (x / (CUT_HALF + 0.002)) ** 2, 0, 1)
    jaw = np.maximum(_smooth(MOUTH_Y + 0.002, MOUTH_Y - 0.012, y), np.where(below, lens, 0.0))
    jaw = jaw * _smooth(-0.01, 0.03, p[:, 2])
    jaw = np.where(in_mouth, _smooth(MOUTH_Y + 0.003, MOUTH_Y - 0.006, y), jaw)
    up_lip = _bump(p, (0, -0.049, 0.088), (0.024, 0.008, 0.02)) * ~below
    low_lip = _bump(p, (0, -0.063, 0.085), (0.024, 0.009, 0.02)) * below
    lips = up_lip + low_lip
    corner = {s: _bump(p, (s * MOUTH_HALF, MOUTH_Y, 0.08), (0.011, 0.011, 0.015)) for s in (1, -1)}
    side = {s: _smooth(-0.004, 0.016, s * x) for s in (1, -1)}
    brow_in = {s: _bump(p, (s * 0.014, 0.030, 0.085), (0.011, 0.008, 0.02)) for s in (1, -1)}
    brow_out = {s: _bump(p, (s * 0.040, 0.028, 0.078), (0.013, 0.008, 0.02)) for s in (1, -1)}
    cheek = {s: _bump(p, (s * 0.040, -0.020, 0.070), (0.016, 0.015, 0.02)) for s in (1, -1)}
    puff = {s: _bump(p, (s * 0.038, -0.048, 0.065), (0.016, 0.016, 0.02)) for s in (1, -1)}
    nose = {s: _bump(p, (s * 0.017, -0.029, 0.097), (0.009, 0.009, 0.01)) for s in (1, -1)}
    tongue = in_mouth & (p[:, 1] < MOUTH_Y - 0.004) & (np.abs(x) < 0.012)
    v = lambda w, d: np.asarray(w)[:, None] * np.asarray(d, float)  # noqa: E731
    lr = {"Left": 1, "Right": -1}
    m = {"jawOpen": _turn(p, JAW_PIVOT, "x", JAW_RAD, jaw),
         "jawForward": v(jaw, (0, 0, 0.006)), "jawLeft": v(jaw, (0.006, 0, 0)), "jawRight": v(jaw, (-0.006, 0, 0)),
         "mouthClose": v(low_lip, (0, 0.004, 0)) + v(up_lip, (0, -0.002, 0)),
         "mouthFunnel": v(lips, (0, 0, 0.006)) + v(corner[1], (-0.004, 0, 0.002)) + v(corner[-1], (0.004, 0, 0.002)),
         "mouthPucker": v(lips, (0, 0, 0.004)) + v(corner[1], (-0.008, 0, 0.003)) + v(corner[-1], (0.008, 0, 0.003)),
         "mouthLeft": v(lips + corner[1] + corner[-1], (0.006, 0, 0)),
         "mouthRight": v(lips + corner[1] + corner[-1], (-0.006, 0, 0)),
         "mouthRollLower": v(low_lip, (0, 0.002, -0.004)), "mouthRollUpper": v(up_lip, (0, -0.002, -0.004)),
         "mouthShrugLower": v(low_lip, (0, 0.004, 0.002)), "mouthShrugUpper": v(up_lip, (0, 0.003, 0.002)),
         "browInnerUp": v(brow_in[1] + brow_in[-1], (0, 0.006, 0)),
         "cheekPuff": v(puff[1], (0.006, 0, 0.002)) + v(puff[-1], (-0.006, 0, 0.002)),
         "tongueOut": v(tongue, (0, -0.004, 0.02))}
    for name, s in lr.items():
        m |= {f"mouthSmile{name}": v(corner[s], (s * 0.004, 0.006, -0.002)),
              f"mouthFrown{name}": v(corner[s], (0, -0.006, 0)),
              f"mouthDimple{name}": v(corner[s], (s * 0.003, 0, -0.004)),
              f"mouthStretch{name}": v(corner[s], (s * 0.006, -0.002, -0.002)),
              f"mouthPress{name}": v(up_lip * side[s], (0, -0.002, 0)) + v(low_lip * side[s], (0, 0.002, 0)),
              f"mouthLowerDown{name}": v(low_lip * side[s], (0, -0.005, 0)),
              f"mouthUpperUp{name}": v(up_lip * side[s], (0, 0.005, 0)),
              f"browDown{name}": v(brow_in[s] + brow_out[s], (0, -0.004, 0.001)),
              f"browOuterUp{name}": v(brow_out[s], (0, 0.006, 0)),
              f"cheekSquint{name}": v(cheek[s], (0, 0.004, 0)),
              f"noseSneer{name}": v(nose[s], (0, 0.003, 0))}
    mix = lambda **k: sum(w * m[n] for n, w in k.items())  # noqa: E731
    stretch = m["mouthStretchLeft"] + m["mouthStretchRight"]
    smile = m["mouthSmileLeft"] + m["mouthSmileRight"]
    press = m["mouthPressLeft"] + m["mouthPressRight"]
    visemes = {"sil": None, "PP": m["mouthClose"] + press, "FF": mix(mouthRollLower=1.0, jawOpen=0.1),
               "TH": mix(jawOpen=0.2, tongueOut=0.4), "DD": mix(jawOpen=0.3) + 0.2 * stretch,
               "kk": mix(jawOpen=0.35) + 0.3 * stretch, "CH": mix(jawOpen=0.2, mouthFunnel=0.6),
               "SS": mix(jawOpen=0.1) + 0.5 * stretch + 0.2 * smile, "nn": mix(jawOpen=0.2) + 0.2 * stretch,
               "RR": mix(jawOpen=0.2, mouthFunnel=0.4, mouthPucker=0.3), "aa": mix(jawOpen=0.7),
               "E": mix(jawOpen=0.4) + 0.5 * stretch, "I": mix(jawOpen=0.25) + 0.5 * smile + 0.4 * stretch,
               "O": mix(jawOpen=0.5, mouthFunnel=0.8), "U": mix(jawOpen=0.2, mouthPucker=1.0)}
    out = {k: m[k] for k in ARKIT_BLENDSHAPES if k in m}
    out |= {f"viseme_{k}": d for k, d in visemes.items()}
    out |= {"mouthOpen": 0.5 * m["jawOpen"], "mouthSmile": smile}
    return out


def eye_morphs(p, centre, s):
    """An eye's blendshapes (``s`` = 1 left, −1 right; ``p`` and ``centre`` in metres)."""
    name = "Left" if s > 0 else "Right"
    ones = np.ones(len(p))
    squash = lambda k: np.c_[np.zeros(len(p)), -k * (p[:, 1] - centre[1]), np.zeros(len(p))]  # noqa: E731
    return {f"eyeBlink{name}": squash(0.88), f"eyeSquint{name}": squash(0.35), f"eyeWide{name}": squash(-0.15),
            f"eyeLookUp{name}": _turn(p, centre, "x", -LOOK_RAD, ones),
            f"eyeLookDown{name}": _turn(p, centre, "x", LOOK_RAD, ones),
            f"eyeLookIn{name}": _turn(p, centre, "y", -s * LOOK_RAD, ones),
            f"eyeLookOut{name}": _turn(p, centre, "y", s * LOOK_RAD, ones)}


def head_and_eyes(eye_spheres, eye_centre) -> list[SkinnedPart]:
    """The ``Face`` and ``HeadNeck`` meshes and the two eyes (module docstring); ``eye_spheres`` as
    :func:`headmotion.web.build_assets.eyes` makes them (the left eye first), ``eye_centre`` the left
    eye's centre relative to HEAD_CENTER."""
    hm = build_head_mesh(detail=0)
    face = hm.part("head")
    rel, tri, src = cut_lips(face.positions - HEAD_CENTER, face.indices.astype(np.int64))
    n_face = len(rel)
    copies = np.arange(n_face) >= len(face.positions)  # the lower lip's side of the cut
    below = copies | (rel[:, 1] < MOUTH_Y)
    below[src[copies]] = False  # the upper lip's side of the cut
    rest = hm.merged(("ears", "neck"))
    mouth_pos, mouth_col, mouth_idx = mouth()
    rel_all = np.vstack([rel, rest.positions - HEAD_CENTER, mouth_pos])
    n_rest, n_mouth = len(rest.positions), len(mouth_pos)
    idx = np.vstack([tri, rest.indices.astype(np.int64) + n_face, mouth_idx + n_face + n_rest])
    nrm = np.vstack([face.normals[src], rest.normals, _normals(mouth_pos, mouth_idx)])
    col = np.vstack([face.colors[src], rest.colors, mouth_col])
    hw = np.r_[face.weights[src], rest.weights, np.ones(n_mouth)]
    is_face = np.r_[np.ones(n_face, bool), np.zeros(n_rest + n_mouth, bool)]
    in_mouth = np.r_[np.zeros(n_face + n_rest, bool), np.ones(n_mouth, bool)]
    morphs = face_morphs(rel_all, np.r_[below, np.zeros(n_rest + n_mouth, bool)], in_mouth)
    for k, d in morphs.items():  # the ears and the neck keep still
        if d is not None:
            morphs[k] = np.where((is_face | in_mouth)[:, None], d, 0.0)
    j, w = _head_joints(hw)
    head = split_moving(SkinnedPart("Face", rel_all + HEAD_CENTER + HEAD_AT, nrm, col, j, w, idx, morphs), "HeadNeck")

    pos, nrm_e, col_e, _, tri_e = eye_spheres
    half = len(pos) // 2
    parts = [*head]
    for s, sl, name in ((1, slice(0, half), "Left"), (-1, slice(half, None), "Right")):
        p = pos[sl] + HEAD_AT
        centre = HEAD_AT + HEAD_CENTER + np.asarray(eye_centre) * [s, 1, 1]
        t = tri_e[: len(tri_e) // 2] if s > 0 else tri_e[len(tri_e) // 2:] - half
        jj, ww = _rigid(len(p), f"{name}Eye")
        parts.append(SkinnedPart(f"Eye{name}", p, nrm_e[sl], col_e[sl], jj, ww, t, eye_morphs(p, centre, s)))
    ex = parts[2].morphs, parts[3].morphs
    for combined, key in (("eyesClosed", "eyeBlink"), ("eyesLookUp", "eyeLookUp"), ("eyesLookDown", "eyeLookDown")):
        ex[0][combined], ex[1][combined] = ex[0][f"{key}Left"], ex[1][f"{key}Right"]
    return parts


def avatar_parts(eye_spheres, eye_centre) -> list[SkinnedPart]:
    """Every mesh of the avatar: the body, the head and the eyes (:func:`head_and_eyes`)."""
    return [body(), *head_and_eyes(eye_spheres, eye_centre)]


__all__ = ["avatar_parts", "body", "head_and_eyes", "face_morphs", "eye_morphs", "cut_lips", "mouth", "capsule",
           "torso", "HEAD_AT", "LOOK_RAD"]
