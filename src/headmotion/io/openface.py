"""OpenFace FeatureExtraction CSV (head pose from video; issue 2 item 3).

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
a frontal face is about zero.  Frames with ``success == 0`` or ``confidence < min_confidence`` are
treated as missing and interpolated (gaps longer than ``max_gap`` s reported).  The frame rate
comes from the ``timestamp`` column (median step) unless ``fps=`` is given.

Libraries considered: py-feat (reads these files through pandas; heavy), pandas (not a
dependency); the stdlib ``csv`` module with ``skipinitialspace`` handles both layouts.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..errors import FormatError
from ..rotations import euler_to_rotvec, unwrap_rotvec
from ..types import Motion
from ._mocap import fill_gaps

REQUIRED = ("pose_Rx", "pose_Ry", "pose_Rz")


def _read_rows(path):
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh, skipinitialspace=True))
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

    ang, tr, ts, ok = [], [], [], []
    for k, row in enumerate(rows):
        ln = k + 2
        if not row or all(not c.strip() for c in row):
            continue
        if "face_id" in ix and col("face_id", row, ln) != face:
            continue
        ang.append([col(c, row, ln) for c in REQUIRED])
        tr.append([col(c, row, ln) for c in ("pose_Tx", "pose_Ty", "pose_Tz")])
        ts.append(col("timestamp", row, ln))
        good = col("success", row, ln, 1.0) != 0 and col("confidence", row, ln, 1.0) >= min_confidence
        ok.append(bool(good))
    if not ang:
        raise FormatError("OpenFace CSV has a header but no frames", path=path)
    ang = np.array(ang)
    tr = np.array(tr) * 1e-3
    ts = np.array(ts)
    ok = np.array(ok) & np.all(np.isfinite(ang), 1)
    if fps is None:
        d = np.diff(ts[np.isfinite(ts)])
        d = d[d > 0]
        if not len(d):
            raise FormatError("cannot infer the frame rate from 'timestamp'; pass fps=", path=path)
        fps = 1.0 / float(np.median(d))
    if not ok.any():
        raise FormatError("no frame with success == 1 and enough confidence", path=path)
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


def openface_info(path) -> dict:
    m = load_openface(path)
    return {"format": "openface", "n_frames": len(m), "fps": m.fps, "duration": m.duration,
            "layout": m.meta["layout"]}


__all__ = ["load_openface", "openface_info"]
