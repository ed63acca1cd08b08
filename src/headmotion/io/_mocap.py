"""Helpers shared by the motion-capture readers (thesis §3.4): gap filling, axis maps, marker
rigid bodies.

* :func:`fill_gaps` — missing frames (NaN rows) are interpolated; gaps up to ``max_gap`` seconds
  silently, longer ones too (a finished :class:`~headmotion.types.Motion` is finite) but reported
  in ``Motion.meta["long_gaps"]`` and with a :class:`MotionGapWarning`.
* :func:`axis_matrix` — the 3×3 matrix taking a file's coordinates to ours (+x speaker's left,
  +y up, +z forward; :mod:`headmotion.rotations`) given the file's up and forward axes.
* :func:`rigid_body_track` — per-frame rotation of a marker set relative to its mean shape by SVD
  (Söderkvist & Wedin 1993, :func:`headmotion.rotations.kabsch`), using whatever ≥ 3 markers are
  present in each frame.

Libraries considered: scipy's ``Rotation.align_vectors`` does the same fit as ``kabsch`` but one
frame at a time without the centroid; the project's ``kabsch`` is used so there is one
implementation.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import ParameterError
from ..rotations import kabsch


class MotionGapWarning(UserWarning):
    """A motion file has a gap longer than the interpolation limit (it was filled anyway)."""


_AXES = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0),
         "+z": (0, 0, 1), "-z": (0, 0, -1)}


def axis_matrix(*, up: str = "+y", forward: str = "+z") -> np.ndarray:
    """Matrix ``M`` with ``v_ours = M @ v_file`` for a file whose up / forward (the way the
    speaker faces) axes are ``up`` and ``forward`` (each one of ``±x, ±y, ±z``).

    A rotation ``R_file`` becomes ``M @ R_file @ M.T`` in our convention."""
    try:
        u = np.array(_AXES[str(up).lower() if str(up)[0] in "+-" else "+" + str(up).lower()], float)
        f = np.array(_AXES[str(forward).lower() if str(forward)[0] in "+-" else "+" + str(forward).lower()], float)
    except (KeyError, IndexError):
        raise ParameterError(f"up/forward must be one of {sorted(_AXES)}; got up={up!r}, forward={forward!r}") from None
    if abs(u @ f) > 0.5:
        raise ParameterError(f"up and forward must be different axes; got up={up!r}, forward={forward!r}")
    left = np.cross(u, f)
    return np.stack([left, u, f])


def nan_runs(bad: np.ndarray) -> list[tuple[int, int]]:
    """``[(start, stop), ...]`` of runs of True in a boolean vector."""
    bad = np.asarray(bad, bool)
    if not bad.any():
        return []
    d = np.diff(np.concatenate([[0], bad.astype(int), [0]]))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def fill_gaps(values: np.ndarray, *, fps: float, max_gap: float = 0.1, path=None,
              what: str = "frames") -> tuple[np.ndarray, dict]:
    """Fill NaN rows of ``values`` ``(T, D)`` by linear interpolation (edges: nearest value).

    Returns the filled array and a report ``{"filled_frames", "short_gaps", "long_gaps":
    [[start_s, stop_s], ...]}``; gaps longer than ``max_gap`` seconds also raise a
    :class:`MotionGapWarning`.  An all-NaN input is returned unchanged (the caller decides)."""
    v = np.array(values, dtype=np.float64)
    bad = ~np.all(np.isfinite(v), axis=1)
    runs = nan_runs(bad)
    report = {"filled_frames": int(bad.sum()), "short_gaps": 0, "long_gaps": [],
              "max_gap_s": float(max_gap)}
    if not runs or bad.all():
        return v, report
    t = np.arange(len(v))
    good = ~bad
    for k in range(v.shape[1]):
        v[bad, k] = np.interp(t[bad], t[good], v[good, k])
    limit = max_gap * fps
    for a, b in runs:
        if (b - a) <= limit + 1e-9:
            report["short_gaps"] += 1
        else:
            report["long_gaps"].append([round(a / fps, 4), round(b / fps, 4)])
    if report["long_gaps"]:
        n = len(report["long_gaps"])
        longest = max(g[1] - g[0] for g in report["long_gaps"])
        where = f"{path}: " if path is not None else ""
        warnings.warn(
            f"{where}{n} gap(s) in the {what} longer than {max_gap:g} s (longest {longest:.3f} s) "
            f"were interpolated; see Motion.meta['gaps']['long_gaps']",
            MotionGapWarning, stacklevel=3,
        )
    return v, report


def mean_shape(points: np.ndarray, *, iterations: int = 3, max_frames: int = 500) -> np.ndarray:
    """Procrustes mean shape ``(N, 3)`` of complete frames ``points`` ``(F, N, 3)``, in the pose
    of the average frame (each frame aligned onto the running mean, then averaged)."""
    p = np.asarray(points, float)
    if len(p) > max_frames:
        p = p[np.linspace(0, len(p) - 1, max_frames).astype(int)]
    ref = p[len(p) // 2].copy()
    for _ in range(iterations):
        acc = np.zeros_like(ref)
        for frame in p:
            r, t = kabsch(frame, ref)
            acc += frame @ r.T + t
        ref = acc / len(p)
    return ref


def rigid_body_track(points: np.ndarray, *, min_markers: int = 3):
    """Rotation and centroid of a marker set over time.

    Parameters
    ----------
    points : np.ndarray [shape=(T, N, 3)], NaN where a marker is missing

    Returns
    -------
    rot : np.ndarray [shape=(T, 3, 3)], NaN where fewer than ``min_markers`` are present;
        ``points[t] ≈ rot[t] @ reference + pos[t]``.  The reference (the Procrustes mean shape)
        is put in the mean orientation of the take (scipy's quaternion mean), so ``rot`` is
        the rotation away from the **mean posture**.
    pos : np.ndarray [shape=(T, 3)], the position of the reference centroid
    reference : np.ndarray [shape=(N, 3)] the mean shape (from frames with every marker present)
    n_complete : int, number of frames with every marker present
    """
    p = np.asarray(points, float)
    present = np.all(np.isfinite(p), axis=2)
    complete = present.all(axis=1)
    if complete.sum() == 0:
        return None, None, None, 0
    try:
        ref = mean_shape(p[complete])
    except np.linalg.LinAlgError:
        return None, None, None, 0
    ref = ref - ref.mean(0)
    T = len(p)
    rot = np.full((T, 3, 3), np.nan)
    pos = np.full((T, 3), np.nan)
    for t in range(T):
        m = present[t]
        if m.sum() < min_markers:
            continue
        try:
            r, tr = kabsch(ref[m], p[t, m])
        except np.linalg.LinAlgError:  # degenerate marker positions: this frame is a gap
            continue
        if np.all(np.isfinite(r)) and np.all(np.isfinite(tr)):
            rot[t] = r
            pos[t] = tr
    # express the reference in the mean orientation, so the rotation is zero at the mean posture
    ok = np.all(np.isfinite(rot.reshape(T, 9)), axis=1)
    if not ok.any():
        return None, None, None, 0
    from scipy.spatial.transform import Rotation  # here: writing motion does not need scipy.spatial

    mean = Rotation.from_matrix(rot[ok]).mean().as_matrix()
    rot[ok] = rot[ok] @ mean.T
    ref = ref @ mean.T
    return rot, pos, ref, int(complete.sum())


__all__ = ["MotionGapWarning", "axis_matrix", "fill_gaps", "nan_runs", "mean_shape", "rigid_body_track"]
