"""SMPL / SMPL-H / SMPL-X parameter files (``.npz``): head rotation relative to the torso.

The seeds are silent on these files (the thesis reads marker mocap, §3.4); they are what today's
large speech-and-motion releases ship (BEAT2 / EMAGE, TalkSHOW, AMASS-style takes): per take an
``.npz`` with ``poses`` — axis-angle vectors, three per joint, each joint's rotation relative to
its parent (the first triple is the global root orientation) — and the capture rate in
``mocap_frame_rate`` (BEAT2, AMASS SMPL-X) or ``mocap_framerate`` (AMASS SMPL-H).

========== ============= ======= =====================================================
model      ``poses``     joints  layout
========== ============= ======= =====================================================
SMPL       (T, 72)       24      body joints 0–23 (22, 23 are the hands)
SMPL-H     (T, 156)      52      body joints 0–21, then 2 × 15 finger joints
SMPL-X     (T, 165)      55      body joints 0–21, jaw 22, eyes 23–24, 2 × 15 fingers
========== ============= ======= =====================================================

``pose_body`` (T, 63) — joints 1–21 without the root, as AMASS's SMPL-X files also hold — is
read when there is no ``poses``.  ``poses`` may also be ``(T, J, 3)``.

Head relative to the torso.  The first 22 joints are the same in all three models: 0 pelvis,
3/6/9 spine1/2/3 (9 is the chest), 12 neck, 15 head.  The chest's child chain to the head is neck
→ head, so the head's rotation in the chest's frame is ``R = R_neck @ R_head`` (the local
rotations of joints 12 and 15, composed parent first); the root, spine and legs do not enter.
(BEAT2 documents SMPL-X joints 12 and 15 as neck and head; SMPL-H and SMPL use the same body
indices.)

Axes.  An SMPL body in its rest pose faces **+z**, with **+y up** and **+x to the body's left**
(the left hip and shoulder have positive x).  That is exactly the project's convention
(:mod:`headmotion.rotations`: +x speaker's left, +y up, +z forward), and every joint's rest frame
is aligned with the body's, so the mapping is the identity: a positive rotation about x turns the
nose from +z towards −y (down) = positive pitch; about y it turns the nose from +z towards +x (the
speaker's left) = positive yaw; about z it takes the top of the head (+y) towards −x (the
speaker's right) = positive roll.  The world frame the root is expressed in (AMASS is z-up) does
not matter, as only neck and head enter.

Bad input: a width that is none of 72 / 156 / 165 (or 63 for ``pose_body``), no frame rate (give
``fps=`` or an ``fps`` column in corpus.csv), a rate outside 1–1000 fps, or a file without poses
is a :class:`~headmotion.errors.FormatError` naming the file and the array.  NaN / inf poses are
gaps, interpolated and reported in ``Motion.meta["gaps"]``.  Files are read with
``allow_pickle=False``.

Libraries considered: ``smplx`` (the models' reference code) and ``human_body_prior`` need the
licensed body-model files and torch to run forward kinematics, which a head rotation does not
need; scipy's :class:`~scipy.spatial.transform.Rotation` does the composition.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import FormatError, HeadMotionError, ParameterError
from ..rotations import unwrap_rotvec
from ..types import Motion
from ._limits import FPS_RANGE, check_fps
from ._mocap import fill_gaps

#: ``poses`` width → (model name, joints).
MODELS = {72: ("smpl", 24), 156: ("smpl-h", 52), 165: ("smpl-x", 55)}
#: Joint indices (in ``poses``) of the chest's child chain to the head, shared by the three models.
NECK, HEAD, CHEST = 12, 15, 9
RATE_KEYS = ("mocap_frame_rate", "mocap_framerate")


def is_smpl_npz(files) -> bool:
    """An ``.npz`` whose arrays look like SMPL parameters (``poses`` or ``pose_body``, no ``rotvec``)."""
    files = set(files)
    return "rotvec" not in files and bool({"poses", "pose_body"} & files)


def _rate(z, path, fps):
    if fps is not None:
        return check_fps(fps, path=path, what="fps=", error=ParameterError), "fps="
    for key in RATE_KEYS:
        if key in z.files:
            a = np.asarray(z[key])
            try:
                v = float(a.reshape(-1)[0]) if a.size == 1 else float("nan")
            except (TypeError, ValueError):
                v = float("nan")
            lo, hi = FPS_RANGE
            if not (np.isfinite(v) and lo <= v <= hi):
                raise FormatError(f"{key} = {a.tolist()!r}; expected one frame rate within "
                                  f"{lo:g}–{hi:g} fps", path=path)
            return v, key
    raise FormatError(f"no frame rate: none of {', '.join(RATE_KEYS)} in the file (arrays: "
                      f"{', '.join(z.files)}); pass fps= or add an fps column to corpus.csv", path=path)


def _poses(z, path):
    """``(T, J, 3)`` local axis-angle rotations with the root at index 0, and the model name."""
    key = "poses" if "poses" in z.files else "pose_body"
    a = np.asarray(z[key])
    if not np.issubdtype(a.dtype, np.number):
        raise FormatError(f"'{key}' holds {a.dtype} values; expected axis-angle numbers", path=path)
    a = a.astype(np.float64)
    if a.ndim == 3 and a.shape[2] == 3:
        a = a.reshape(len(a), -1)
    if key == "pose_body":
        if a.ndim != 2 or a.shape[1] != 63:
            raise FormatError(f"'pose_body' has shape {a.shape}; expected (frames, 63) (21 body joints "
                              f"× 3, root excluded)", path=path)
        a = np.concatenate([np.zeros((len(a), 3)), a], axis=1)  # put the root back at index 0
        model = "smpl-x (pose_body)"
    else:
        if a.ndim != 2 or a.shape[1] not in MODELS:
            raise FormatError(
                f"'poses' has shape {a.shape}; expected (frames, 72) SMPL, (frames, 156) SMPL-H or "
                f"(frames, 165) SMPL-X axis-angle values", path=path)
        model = MODELS[a.shape[1]][0]
    if len(a) == 0:
        raise FormatError(f"'{key}' has no frames", path=path)
    return a.reshape(len(a), -1, 3), model, key


def load_smpl(path, *, fps: float | None = None, max_gap: float = 0.1) -> Motion:
    """Head rotation relative to the chest (neck ∘ head) from an SMPL / SMPL-H / SMPL-X ``.npz``.

    Parameters
    ----------
    path : str or Path
    fps : float, optional, overrides ``mocap_frame_rate`` / ``mocap_framerate``
    max_gap : float, NaN stretches longer than this (s) are reported as long gaps

    Returns
    -------
    Motion, ``rotvec (T, 3)`` in the convention of :mod:`headmotion.rotations` (identity map)
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            if not is_smpl_npz(z.files):
                raise FormatError(f"no 'poses' or 'pose_body' array (arrays: {', '.join(z.files)}); "
                                  f"expected SMPL / SMPL-H / SMPL-X parameters", path=path)
            poses, model, key = _poses(z, path)
            rate, rate_key = _rate(z, path, fps)
    except HeadMotionError:
        raise
    except (zipfile.BadZipFile, OSError, EOFError) as exc:
        raise FormatError(f"not a readable .npz file ({exc})", path=path) from None
    except ValueError as exc:
        raise FormatError(f"damaged or pickled .npz content ({exc})", path=path) from None
    neck, head = poses[:, NECK], poses[:, HEAD]
    ok = np.all(np.isfinite(neck), 1) & np.all(np.isfinite(head), 1)
    if not ok.any():
        raise FormatError(f"'{key}' has no finite neck/head values (joints {NECK}, {HEAD})", path=path)
    rv = np.full((len(poses), 3), np.nan)
    rv[ok] = unwrap_rotvec((Rotation.from_rotvec(neck[ok]) * Rotation.from_rotvec(head[ok])).as_rotvec())
    filled, report = fill_gaps(rv, fps=rate, max_gap=max_gap, path=path, what="poses")
    meta = {"source": str(path), "format": "smpl", "model": model, "head_joint": f"neck({NECK})·head({HEAD})",
            "relative_to": f"chest({CHEST})", "rate_from": rate_key, "gaps": report}
    return Motion(filled, rate, meta=meta)


__all__ = ["load_smpl", "is_smpl_npz", "MODELS", "NECK", "HEAD", "CHEST"]
