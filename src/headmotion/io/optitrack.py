"""OptiTrack Motive CSV exports (thesis §3.4; paper §4.1).

Layout (Motive 1.x–3.x): line 1 holds ``key,value`` pairs (``Format Version``, ``Capture Frame
Rate``, ``Export Frame Rate``, ``Rotation Type`` = ``Quaternion`` or an Euler order such as
``XYZ``, ``Length Units``, …); then rows whose second cell is ``Type`` (``Rigid Body``, ``Rigid
Body Marker``, ``Marker``, ``Bone``…), ``Name``, ``ID`` (and possibly ``Parent``), a row naming
the quantity (``Rotation``, ``Position``, ``Mean Marker Error``, …), the axis row starting with
``Frame,Time (Seconds)`` (``X,Y,Z,W`` for quaternions) and one row per frame.  Empty cells are
missing values (NaN).  A file with no object columns raises :class:`FormatError`.

What is computed (thesis §3.4: "the motion of the head and body was re-estimated using SVD
(Söderkvist and Wedin, 1993). The mean position ... was reset to the zero vector"):

* **Rigid bodies present** — the head body (``head=`` name, or the one whose name contains
  "head", or the only one) and the torso body (``body=``, or one named body/torso/chest/jacket/
  trunk).  Quaternions are (x, y, z, w); Euler columns use the file's ``Rotation Type`` as an
  intrinsic order in degrees.  Head relative to body = ``R_body^T R_head``; without a body rigid
  body the head rotation is relative to the lab (``meta["relative_to"] = "world"``).
* **Only markers** — rotation of a named marker set by SVD against its Procrustes mean shape
  (from the frames where all its markers are present), per frame from the ≥ 3 markers present:
  ``head_markers=[...]`` relative to ``body_markers=[...]``.  Without names, markers whose names
  start with ``head`` / (``body``, ``torso``, ``chest``, ``jacket``) form the sets (Motive names
  labelled markers ``Head:Marker1`` …).  **Fallback** for unlabelled data (e.g. ``Unlabeled
  1036`` …): every marker present in at least ``min_presence`` (default 90 %) of frames is treated
  as one rigid body, relative to the lab, and ``meta["fallback"]`` says so (plus a warning).
  With markers each set's rest pose is its mean shape in its mean orientation over the take,
  so the head rotation is zero when head and torso are both in their mean postures.

Translation: the head's position relative to the body (in the body's frame; or in the lab),
metres, with the mean position reset to zero.  Short gaps (≤ ``max_gap`` s, default 0.1 s) are
interpolated, longer ones too but reported in ``meta["gaps"]`` and with a warning.

Axes: Motive is right-handed, Y-up; we assume the speaker faces Motive's +Z (so Motive +X is the
speaker's left, matching ours); give ``forward="-z"`` (or ``±x``) otherwise.  A rotation becomes
``M R M^T`` with ``M`` from :func:`headmotion.io._mocap.axis_matrix`.

Libraries considered: none maintained parses Motive CSVs with rigid bodies (``optitrack-csv``
style gists only); pandas is not a dependency; the stdlib ``csv`` module is enough.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import FormatError, NoHeadError, ParameterError
from ..types import Motion
from ._limits import FPS_RANGE, check_fps, check_size, csv_rows
from ._mocap import axis_matrix, fill_gaps, rigid_body_track

#: coordinates beyond this (in the file's length unit, mm by default: 1000 km) are damage, not data
_MAX_COORD = 1e9

_UNITS = {"millimeters": 1e-3, "millimetres": 1e-3, "centimeters": 1e-2, "centimetres": 1e-2,
          "meters": 1.0, "metres": 1.0}
_BODY_WORDS = ("body", "torso", "chest", "jacket", "trunk", "back")


class MotiveCSV:
    """Parsed Motive CSV: header dict, per-column descriptors and the data matrix."""

    def __init__(self, path):
        self.path = Path(path)
        check_size(self.path, what="Motive CSV")
        try:
            with open(self.path, newline="", encoding="utf-8-sig", errors="replace") as fh:
                rows = [r for _, r in csv_rows(fh, path=self.path)]
        except OSError as exc:
            raise FormatError(f"cannot read Motive CSV: {exc.strerror}", path=path) from None
        if not rows:
            raise FormatError("file is empty (expected a Motive CSV export)", path=path)
        first = rows[0]
        if not first or first[0].strip() != "Format Version":
            raise FormatError("expected 'Format Version' in the first cell of a Motive CSV", path=path, line=1)
        self.header = {first[k].strip(): first[k + 1].strip() for k in range(0, len(first) - 1, 2)}
        desc: dict[str, list[str]] = {}
        frame_row = None
        for i, row in enumerate(rows[1:40], start=1):
            if not row:
                continue
            if row[0].strip() == "Frame":
                frame_row = i
                break
            if len(row) > 1 and row[1].strip() in ("Type", "Name", "ID", "Parent"):
                desc[row[1].strip()] = row
        if frame_row is None:
            raise FormatError("no 'Frame,Time' header row found in the first 40 lines", path=path)
        self.axes_row = rows[frame_row]
        kind = rows[frame_row - 1] if frame_row - 1 >= 1 else []
        n = len(self.axes_row)
        pad = lambda r: [c.strip() for c in r] + [""] * (n - len(r))  # noqa: E731
        types, names, kinds = pad(desc.get("Type", [])), pad(desc.get("Name", [])), pad(kind)
        axes = pad(self.axes_row)
        self.columns = [(types[j], names[j], kinds[j], axes[j]) for j in range(n)]
        objects = [c for c in self.columns[2:] if c[0]]
        if not objects:
            raise FormatError("the Motive CSV holds no objects (no rigid body or marker columns)", path=path,
                              line=frame_row + 1)
        data = []
        for k, row in enumerate(rows[frame_row + 1:]):
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) > n:
                raise FormatError(f"row has {len(row)} cells, the header has {n}", path=path,
                                  line=frame_row + 2 + k)
            try:
                data.append([float(c) if c.strip() else np.nan for c in row] + [np.nan] * (n - len(row)))
            except ValueError:
                bad = next(c for c in row if c.strip() and not _is_float(c))
                raise FormatError(f"the cell {bad.strip()[:40]!r} is not a number", path=path,
                                  line=frame_row + 2 + k) from None
        if not data:
            raise FormatError("the Motive CSV has a header but no frames", path=path)
        self.data = np.array(data)
        self.data_line = frame_row + 2
        # NaN/inf cells are gaps like empty cells; absurd magnitudes are damage
        vals = self.data[:, 2:]
        with np.errstate(invalid="ignore"):
            huge = np.isfinite(vals) & (np.abs(vals) > _MAX_COORD)
        if huge.any():
            r, c = np.argwhere(huge)[0]
            raise FormatError(f"the value {vals[r, c]:g} in column {c + 3} is not a plausible coordinate "
                              f"or rotation (|value| > {_MAX_COORD:g})", path=path,
                              line=self.data_line + int(r))
        self.data[:, 2:][~np.isfinite(vals)] = np.nan

    @property
    def fps(self) -> float:
        """The header's Export (else Capture) Frame Rate, checked (1–1000 fps); without either,
        from the median step of the Time column."""
        for key in ("Export Frame Rate", "Capture Frame Rate"):
            v = self.header.get(key, "").strip()
            if v:
                return check_fps(v, path=self.path, line=1, what=f"'{key}'")
        t = self.data[:, 1]
        d = np.diff(t[np.isfinite(t)])
        d = d[d > 0]
        if len(d):
            step = float(np.median(d))
            return check_fps(1.0 / step, path=self.path, what=f"the Time column's step ({step:g} s) gives a frame rate")
        raise FormatError(f"no frame rate: the header has no Export/Capture Frame Rate and the Time column "
                          f"has no increasing steps (expected {FPS_RANGE[0]:g}–{FPS_RANGE[1]:g} frames/s)",
                          path=self.path)

    @property
    def unit_scale(self) -> float:
        return _UNITS.get(self.header.get("Length Units", "Millimeters").lower(), 1e-3)

    def names(self, type_: str) -> list[str]:
        seen: list[str] = []
        for t, n, _, _ in self.columns[2:]:
            if t == type_ and n not in seen:
                seen.append(n)
        return seen

    def block(self, type_: str, name: str, kind: str, axes: str) -> np.ndarray | None:
        idx = []
        for a in axes:
            j = [k for k, c in enumerate(self.columns) if c[0] == type_ and c[1] == name and c[2] == kind and c[3] == a]
            if not j:
                return None
            idx.append(j[0])
        return self.data[:, idx]

    def markers(self) -> dict[str, np.ndarray]:
        out = {}
        for n in self.names("Marker"):
            b = self.block("Marker", n, "Position", "XYZ")
            if b is not None:
                out[n] = b
        return out


def _is_float(c: str) -> bool:
    try:
        float(c)
    except ValueError:
        return False
    return True


def _pick(names: list[str], given: str | None, words, what: str, path) -> str | None:
    if given is not None:
        if given not in names:
            raise NoHeadError(f"no rigid body named {given!r} for the {what}; rigid bodies: {', '.join(names) or 'none'}",
                              path=path)
        return given
    hits = [n for n in names if any(w in n.lower() for w in words)]
    return hits[0] if hits else None


def _rigid_body_rotation(mc: MotiveCSV, name: str) -> tuple[np.ndarray, np.ndarray]:
    rt = mc.header.get("Rotation Type", "Quaternion")
    pos = mc.block("Rigid Body", name, "Position", "XYZ")
    if rt.lower() == "quaternion":
        q = mc.block("Rigid Body", name, "Rotation", "XYZW")
        if q is None:
            raise FormatError(f"rigid body {name!r} has no Rotation X,Y,Z,W columns", path=mc.path)
        mat = np.full((len(q), 3, 3), np.nan)
        norm = np.linalg.norm(np.nan_to_num(q), axis=1)
        ok = np.all(np.isfinite(q), 1) & (norm > 0.5) & (norm < 2.0)  # Motive writes unit quaternions
        mat[ok] = Rotation.from_quat(q[ok]).as_matrix()  # scalar last: (x, y, z, w)
    else:
        order = rt.upper()
        e = mc.block("Rigid Body", name, "Rotation", "XYZ")
        if e is None or len(order) != 3 or set(order) - set("XYZ"):
            raise FormatError(f"rigid body {name!r}: unsupported Rotation Type {rt!r}", path=mc.path)
        e = e[:, ["XYZ".index(a) for a in order]]
        mat = np.full((len(e), 3, 3), np.nan)
        ok = np.all(np.isfinite(e), 1)
        mat[ok] = Rotation.from_euler(order, e[ok], degrees=True).as_matrix()
    if pos is None:
        pos = np.zeros((len(mat), 3))
    return mat, pos


def _marker_set(markers: dict[str, np.ndarray], names, what: str, path) -> np.ndarray:
    missing = [n for n in names if n not in markers]
    if missing:
        raise NoHeadError(f"{what} markers not in the file: {', '.join(missing)}; markers available: "
                          f"{', '.join(markers) or 'none'}", path=path)
    if len(names) < 3:
        raise ParameterError(f"{path}: a rigid body needs at least 3 {what} markers; got {list(names)}")
    return np.stack([markers[n] for n in names], axis=1)


def load_optitrack(path, *, head: str | None = None, body: str | None = None,
                   head_markers=None, body_markers=None, max_gap: float = 0.1,
                   min_presence: float = 0.9, forward: str = "+z", up: str = "+y") -> Motion:
    """Head rotation relative to the torso from a Motive CSV export (see the module docstring).

    Parameters
    ----------
    head, body : str, optional
        Rigid-body names.
    head_markers, body_markers : list of str, optional
        Marker names forming the head / torso rigid bodies when the file has only markers.
    max_gap : float
        Longest gap (seconds) filled without a warning.
    min_presence : float
        Fallback for unlabelled markers: keep markers present in this fraction of frames.
    forward, up : str
        The way the speaker faces and the up axis in Motive's coordinates.

    Returns
    -------
    Motion, ``rotvec (T, 3)`` and ``translation (T, 3)`` in metres (mean reset to zero).
    """
    mc = MotiveCSV(path)
    fps = mc.fps
    scale = mc.unit_scale
    meta: dict = {"source": str(path), "format": "optitrack", "format_version": mc.header.get("Format Version"),
                  "take": mc.header.get("Take Name"), "rigid_bodies": mc.names("Rigid Body"),
                  "markers": mc.names("Marker")}
    rbs = mc.names("Rigid Body")
    rot_b = pos_b = None
    if rbs and head_markers is None:
        hname = _pick(rbs, head, ("head", "cap", "hat"), "head", path)
        if hname is None:
            if len(rbs) == 1:
                hname = rbs[0]
            else:
                raise NoHeadError(f"cannot tell which rigid body is the head; rigid bodies: {', '.join(rbs)}; "
                                  f"pass head='NAME'", path=path)
        bname = _pick([n for n in rbs if n != hname], body, _BODY_WORDS, "body", path)
        rot_h, pos_h = _rigid_body_rotation(mc, hname)
        if bname is not None:
            rot_b, pos_b = _rigid_body_rotation(mc, bname)
        meta.update(source_kind="rigid_body", head=hname, relative_to=bname or "world")
    else:
        markers = mc.markers()
        if not markers:
            raise NoHeadError("no rigid body and no marker position columns", path=path)
        if head_markers is None:
            head_markers = [n for n in markers if n.lower().startswith("head")]
            if body_markers is None:
                body_markers = [n for n in markers if n.lower().startswith(_BODY_WORDS)] or None
            if len(head_markers) < 3:
                present = {n: float(np.mean(np.all(np.isfinite(v), 1))) for n, v in markers.items()}
                head_markers = [n for n, p in present.items() if p >= min_presence]
                body_markers = None
                if len(head_markers) < 3:
                    raise NoHeadError(
                        f"no head markers named, and fewer than 3 markers are present in {min_presence:.0%} "
                        f"of frames; markers: {', '.join(markers)}; pass head_markers=[...]", path=path)
                meta["fallback"] = (f"no head/body markers named: the {len(head_markers)} markers present in "
                                    f">= {min_presence:.0%} of frames were treated as one rigid body, "
                                    f"relative to the lab")
                warnings.warn(f"{path}: {meta['fallback']}", UserWarning, stacklevel=2)
        pts_h = _marker_set(markers, list(head_markers), "head", path)
        rot_h, pos_h, _, n_complete = rigid_body_track(pts_h)
        if rot_h is None:
            raise NoHeadError(f"the head markers {list(head_markers)} are never all present in one frame, "
                              f"so no reference shape can be built", path=path)
        meta.update(source_kind="markers", head_markers=list(head_markers), complete_head_frames=n_complete)
        if body_markers:
            pts_b = _marker_set(markers, list(body_markers), "body", path)
            rot_b, pos_b, _, nb = rigid_body_track(pts_b)
            if rot_b is None:
                raise NoHeadError(f"the body markers {list(body_markers)} are never all present in one frame",
                                  path=path)
            meta.update(body_markers=list(body_markers), relative_to="body_markers")
        else:
            meta["relative_to"] = "world"
    m = axis_matrix(up=up, forward=forward)
    if rot_b is not None:
        rel = np.einsum("tji,tjk->tik", rot_b, rot_h)  # R_b^T R_h
        pos = np.einsum("tji,tj->ti", rot_b, pos_h - pos_b)
    else:
        rel = rot_h
        pos = pos_h
    T = len(rel)
    bad = ~np.all(np.isfinite(rel.reshape(T, 9)), 1) | ~np.all(np.isfinite(pos), 1)
    if bad.all():
        raise NoHeadError("the head (or body) is missing in every frame", path=path)
    rv = np.full((T, 3), np.nan)
    rv[~bad] = Rotation.from_matrix(m @ rel[~bad] @ m.T).as_rotvec()
    from ..rotations import unwrap_rotvec

    rv[~bad] = unwrap_rotvec(rv[~bad])
    tr = np.where(bad[:, None], np.nan, (pos @ m.T) * scale)
    filled, report = fill_gaps(np.hstack([rv, tr]), fps=fps, max_gap=max_gap, path=path)
    meta["gaps"] = report
    tr = filled[:, 3:]
    tr = tr - tr.mean(0)  # mean position reset (thesis §3.4)
    return Motion(filled[:, :3], fps, translation=tr, meta=meta)


def optitrack_info(path) -> dict:
    mc = MotiveCSV(path)
    return {"format": "optitrack", "n_frames": len(mc.data), "fps": mc.fps, "duration": len(mc.data) / mc.fps,
            "format_version": mc.header.get("Format Version"), "rigid_bodies": mc.names("Rigid Body"),
            "markers": mc.names("Marker"),
            "missing_cells": float(np.mean(np.isnan(mc.data[:, 2:])))}


__all__ = ["load_optitrack", "optitrack_info", "MotiveCSV"]
