"""OpenFace FeatureExtraction CSV (head pose from video).

Both layouts are read: the older one with a space after every comma (``frame, timestamp,
confidence, success, ..., pose_Rx, pose_Ry, pose_Rz, ...``) and OpenFace 2.x's (no spaces,
``face_id`` column; only ``face_id == face`` rows are used, default 0).

Axes.  OpenFace reports ``pose_Rx, pose_Ry, pose_Rz`` in radians as Euler angles of the head in
**camera coordinates** (x to the image's right, y down, z away from the camera into the scene),
composed ``R = Rx @ Ry @ Rz`` (OpenFace's ``Euler2RotationMatrix``; intrinsic ``"XYZ"`` in scipy).
The speaker faces the camera, so the image's right is the speaker's left (our +x), image-down is
our −y and "away from the camera" is our −z (the nose points at the camera).  The change of basis
is ``C = diag(1, −1, −1)`` (a half turn about x) and ``R_ours = C R C``; since ``C Rx(a) C =
Rx(a)``, ``C Ry(b) C = Ry(−b)``, ``C Rz(c) C = Rz(−c)``, this is intrinsic ``"XYZ"`` with angles
``(Rx, −Ry, −Rz)``.  Check: positive ``pose_Rx`` turns the nose (camera −z) towards camera +y
(down), and positive pitch is nose-down in ours too.

The rotation is relative to the **camera**, not the torso (``meta["relative_to"] = "camera"``);
a frontal face is about zero.

Frame rate.  OpenFace writes ``timestamp`` rounded to the millisecond (0.000, 0.033, 0.067, …),
so the median step of a 30 fps file is 0.033 s (30.3 fps) and a 20 s take would drift by 0.15 s.
The rate is therefore taken from the whole span: ``(frame_last − frame_first) / (t_last −
t_first)`` (row count − 1 without a ``frame`` column), and snapped to the nearest standard rate
(:data:`STANDARD_RATES`) when within 0.5 % of it, or within the millisecond rounding of the span
(``0.001 / span``) for short files.  ``fps=`` overrides it; a manifest's ``fps`` column does the
same for a corpus.  Rates must be finite and within 1–1000 fps.

Gaps.  Frames with ``success == 0`` or ``confidence < min_confidence`` (or NaN/inf pose values)
and frame numbers missing from the ``frame`` column (rows a user filtered out) are NaN frames
that are interpolated; gaps longer than ``max_gap`` s are kept interpolated but reported in
``Motion.meta["gaps"]["long_gaps"]`` with a warning.  Timestamps or frame numbers that go
backwards are an error naming the line.

Libraries considered: py-feat (reads these files through pandas; heavy), pandas (not a
dependency); the stdlib ``csv`` module with ``skipinitialspace`` handles both layouts.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._limits import FPS_RANGE, check_fps, csv_rows
from ..errors import FormatError, ParameterError
from ..rotations import euler_to_rotvec, unwrap_rotvec
from ..types import Motion
from ._mocap import fill_gaps

REQUIRED = ("pose_Rx", "pose_Ry", "pose_Rz")
#: Frame rates a measured rate is snapped to (video and camera rates).
STANDARD_RATES = (23.976, 24.0, 25.0, 29.97, 30.0, 50.0, 59.94, 60.0, 100.0, 120.0)


def snap_rate(fps: float, *, span: float | None = None, tolerance: float = 0.005) -> float:
    """``fps`` moved to the nearest of :data:`STANDARD_RATES` when within ``tolerance`` (relative)
    of it, or within the millisecond rounding of a ``span``-second timestamp range; else ``fps``."""
    std = np.array(STANDARD_RATES)
    k = int(np.argmin(np.abs(std - fps) / std))
    tol = tolerance if span is None or span <= 0 else max(tolerance, 1e-3 / span)
    return float(std[k]) if abs(std[k] - fps) / std[k] <= tol else float(fps)


def _read_rows(path):
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = [row for _, row in csv_rows(fh, path=path, skipinitialspace=True)]
    except (OSError, UnicodeDecodeError) as exc:
        raise FormatError(f"cannot read OpenFace CSV ({exc})", path=path) from None
    if not rows:
        raise FormatError("file is empty (expected an OpenFace CSV)", path=path)
    cols = [c.strip() for c in rows[0]]
    missing = [c for c in REQUIRED if c not in cols]
    if missing:
        raise FormatError(f"not an OpenFace CSV: columns {', '.join(missing)} missing", path=path, line=1)
    return path, cols, rows[1:]


def load_openface(path, *, fps: float | None = None, min_confidence: float = 0.5, max_gap: float = 0.1,
                  face: int = 0) -> Motion:
    """Head rotation (relative to the camera) from an OpenFace CSV.

    Returns
    -------
    Motion with ``rotvec (T, 3)``, translation from ``pose_T*`` (mm → m, mean reset) when present.
    """
    path, cols, rows = _read_rows(path)
    ix = {c: k for k, c in enumerate(cols)}

    def col(name, row, ln, default=np.nan):
        if name not in ix:
            return default
        v = row[ix[name]].strip() if ix[name] < len(row) else ""
        if not v:
            return np.nan
        try:
            return float(v)
        except ValueError:
            raise FormatError(f"{name} = {v!r} is not a number", path=path, line=ln) from None

    ang, tr, ts, fr, ok, lines = [], [], [], [], [], []
    for k, row in enumerate(rows):
        ln = k + 2
        if not row or all(not c.strip() for c in row):
            continue
        if "face_id" in ix and col("face_id", row, ln) != face:
            continue
        ang.append([col(c, row, ln) for c in REQUIRED])
        tr.append([col(c, row, ln) for c in ("pose_Tx", "pose_Ty", "pose_Tz")])
        ts.append(col("timestamp", row, ln))
        fr.append(col("frame", row, ln))
        good = col("success", row, ln, 1.0) != 0 and col("confidence", row, ln, 1.0) >= min_confidence
        ok.append(bool(good))
        lines.append(ln)
    if not ang:
        raise FormatError("OpenFace CSV has a header but no frames", path=path)
    ang = np.array(ang)
    tr = np.array(tr) * 1e-3
    ts = np.array(ts)
    fr = np.array(fr)
    lines = np.array(lines)
    ok = np.array(ok) & np.all(np.isfinite(ang), 1)
    for name, v in (("timestamp", ts), ("frame", fr)):
        fin = np.isfinite(v)
        back = np.flatnonzero(np.diff(v[fin]) < 0) if name == "timestamp" else np.flatnonzero(np.diff(v[fin]) <= 0)
        if len(back):
            i, j = np.flatnonzero(fin)[back[0]], np.flatnonzero(fin)[back[0] + 1]
            raise FormatError(
                f"{name} goes backwards ({v[i]:g} then {v[j]:g}); expected increasing {name}s "
                f"(one face, one video per file)", path=path, line=int(lines[j]))
    # position of each row on the frame grid: from the frame numbers when present (rows that were
    # left out become gaps), else one row per frame
    use_frame = np.isfinite(fr).all() and np.all(fr == np.round(fr))
    pos = (fr - fr[0]).astype(int) if use_frame else np.arange(len(ang))
    if fps is None:
        fin = np.isfinite(ts)
        span = float(ts[fin][-1] - ts[fin][0]) if fin.sum() > 1 else 0.0
        steps = int(pos[np.flatnonzero(fin)[-1]] - pos[np.flatnonzero(fin)[0]]) if fin.sum() > 1 else 0
        if not (span > 0 and steps > 0):
            raise FormatError("cannot infer the frame rate: the 'timestamp' column does not advance; "
                              "pass fps= (or an fps column in corpus.csv)", path=path)
        fps = snap_rate(steps / span, span=span)
        lo, hi = FPS_RANGE
        if not (lo <= fps <= hi):
            raise FormatError(f"timestamps give a frame rate of {fps:.6g} fps ({steps} frames in "
                              f"{span:.6g} s); expected {lo:g}–{hi:g} fps; pass fps=", path=path)
    else:
        fps = check_fps(fps, path=path, what="fps=", error=ParameterError)
    if not ok.any():
        raise FormatError("no frame with success == 1 and enough confidence", path=path)
    n = int(pos[-1]) + 1
    if n > 10 * len(pos) + 1000:
        raise FormatError(f"frame numbers jump from {int(fr[0])} to {int(fr[-1])} over only {len(pos)} rows; "
                          f"expected one row per frame (with few rows missing)", path=path)
    grid_ang = np.full((n, 3), np.nan)
    grid_tr = np.full((n, 3), np.nan)
    grid_ang[pos[ok]] = ang[ok]
    grid_tr[pos[ok]] = tr[ok]
    ang, tr = grid_ang, grid_tr
    ok = np.all(np.isfinite(ang), 1)
    rv = np.full((len(ang), 3), np.nan)
    a = ang[ok] * np.array([1.0, -1.0, -1.0])
    rv[ok] = unwrap_rotvec(euler_to_rotvec(a, "XYZ"))
    C = np.diag([1.0, -1.0, -1.0])
    trc = np.where(ok[:, None], tr @ C, np.nan)
    has_t = np.isfinite(trc).all(1).any()
    vals = np.hstack([rv, trc]) if has_t else rv
    filled, report = fill_gaps(vals, fps=fps, max_gap=max_gap, path=path, what="tracked frames")
    t_out = None
    if has_t:
        t_out = filled[:, 3:] - filled[:, 3:].mean(0)
    meta = {"source": str(path), "format": "openface", "relative_to": "camera", "gaps": report,
            "layout": "2.x" if "face_id" in ix else "1.x"}
    return Motion(filled[:, :3], fps, translation=t_out, meta=meta)


__all__ = ["load_openface", "snap_rate", "STANDARD_RATES"]
