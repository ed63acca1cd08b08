"""The project's own motion files: CSV, JSON and NPZ (docs/design.md "Core types"; thesis §2.2.3).

All three hold rotation vectors in radians in our axis convention (:mod:`headmotion.rotations`:
+x speaker's left, +y up, +z forward; columns ``rx, ry, rz`` ≈ pitch, yaw, roll), the frame rate,
optional translation (metres) and the metadata dict.  No axis mapping is needed.

* **NPZ** — arrays ``rotvec (T, 3)``, ``fps ()``, optional ``translation (T, 3)``, and
  ``meta_json`` (a unicode scalar holding JSON); read with ``allow_pickle=False``.
* **JSON** — ``{"format": "headmotion-motion", "version": 1, "fps", "rotation", "columns",
  "units", "frames": [[...], ...], "translation"?, "meta"}``.
* **CSV** — first line ``# headmotion-motion 1 {json: fps, rotation, units, euler_order, meta}``,
  then a header ``frame,time,<3 rotation columns>[,tx,ty,tz]`` and one row per frame.  A CSV
  without the comment line is accepted when it has a ``time`` column (fps from the time steps)
  or when ``fps=`` is given.

Export options for CSV and JSON: ``degrees=True`` writes degrees; ``euler_order="YXZ"`` (any
scipy order) writes Euler angles instead of the rotation vector, columns named after the axis each
angle turns about (x → ``pitch``, y → ``yaw``, z → ``roll``) in the order of the sequence, e.g.
``yaw,pitch,roll`` for ``"YXZ"``.  Both are recorded in the file and re-read exactly.

Libraries considered: pandas (not a dependency; the stdlib ``csv`` module suffices), numpy's own
``.npy`` / ``.npz`` (used), msgpack (unneeded).
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from ..errors import FormatError, ParameterError
from ..rotations import _check_order, euler_to_rotvec, rotvec_to_euler
from ..types import Motion
from ._limits import check_fps, check_size, csv_rows, load_json as _load_json_bounded, load_npz_arrays, read_text
from .atomic import atomic_open, atomic_path

MAGIC = "headmotion-motion"
VERSION = 1
_AXIS_WORD = {"x": "pitch", "y": "yaw", "z": "roll"}


def _jsonable(meta: dict) -> dict:
    def conv(v):
        if isinstance(v, dict):
            return {str(k): conv(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [conv(x) for x in v]
        if isinstance(v, np.ndarray):
            return conv(v.tolist())
        if isinstance(v, np.generic):
            return v.item()
        if isinstance(v, Path):
            return str(v)
        if v is None or isinstance(v, (str, int, float, bool)):
            return v
        return str(v)

    return conv(dict(meta))


def _columns(euler_order: str | None, degrees: bool) -> list[str]:
    unit = "deg" if degrees else "rad"
    if euler_order is None:
        return [f"rx_{unit}", f"ry_{unit}", f"rz_{unit}"] if degrees else ["rx", "ry", "rz"]
    order = _check_order(euler_order)
    return [f"{_AXIS_WORD[a.lower()]}_{unit}" for a in order]


def _encode(motion: Motion, euler_order, degrees) -> np.ndarray:
    if euler_order is None:
        v = np.array(motion.rotvec)
        return np.degrees(v) if degrees else v
    return rotvec_to_euler(motion.rotvec, euler_order, degrees=degrees)


def _decode(values: np.ndarray, rotation: str, euler_order, degrees) -> np.ndarray:
    if rotation == "rotvec":
        return np.radians(values) if degrees else values
    if rotation == "euler":
        if not euler_order:
            raise ParameterError("Euler columns need an euler_order")
        return euler_to_rotvec(values, euler_order, degrees=degrees)
    raise ParameterError(f"rotation must be 'rotvec' or 'euler'; got {rotation!r}")


def _check_motion(motion):
    if not isinstance(motion, Motion):
        raise ParameterError(f"expected a Motion; got {type(motion).__name__}")


# --------------------------------------------------------------------------------------- NPZ
def save_npz(motion: Motion, path) -> None:
    """Write ``motion`` as ``.npz`` (no pickled objects)."""
    _check_motion(motion)
    arrays = {"rotvec": np.asarray(motion.rotvec), "fps": np.float64(motion.fps),
              "meta_json": np.array(json.dumps(_jsonable(motion.meta))),
              "format": np.array(f"{MAGIC} {VERSION}")}
    if motion.translation is not None:
        arrays["translation"] = np.asarray(motion.translation)
    with atomic_path(path, suffix=".npz") as tmp:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)


def load_npz(path) -> Motion:
    path = Path(path)
    check_size(path, what=".npz file")
    z = load_npz_arrays(path, path=path)  # sizes checked before anything is decompressed
    if "rotvec" not in z:
        raise FormatError(f"no 'rotvec' array (arrays: {', '.join(z) or 'none'}); expected a "
                          f"headmotion motion .npz", path=path)
    if "fps" not in z:
        raise FormatError("no 'fps' array", path=path)
    fps_arr = z["fps"]
    if fps_arr.size != 1 or fps_arr.dtype.kind not in "iuf":
        raise FormatError(f"'fps' must be one number; found shape {fps_arr.shape}, dtype {fps_arr.dtype}", path=path)
    fps = check_fps(fps_arr.reshape(()).item(), path=path, what="'fps'")
    rotvec = _numeric(z["rotvec"], "rotvec", path)
    tr = _numeric(z["translation"], "translation", path) if "translation" in z else None
    meta = {}
    if "meta_json" in z:
        mj = z["meta_json"]
        if mj.dtype.kind != "U" or mj.size != 1:
            raise FormatError("'meta_json' must be one string", path=path)
        meta = _load_json_bounded(str(mj.reshape(()).item()), path=path, what="'meta_json'")
        if not isinstance(meta, dict):
            raise FormatError(f"'meta_json' must hold a JSON object; found {type(meta).__name__}", path=path)
    if rotvec.ndim != 2 or rotvec.shape[1] != 3:
        raise FormatError(f"'rotvec' must have shape (T, 3); found {rotvec.shape}", path=path)
    return _motion(rotvec, fps, tr, meta, path)


def _numeric(a: np.ndarray, name: str, path) -> np.ndarray:
    if a.dtype.kind not in "iuf":
        raise FormatError(f"'{name}' must hold numbers; found dtype {a.dtype}", path=path)
    return np.asarray(a, dtype=np.float64)


def _motion(rotvec, fps, translation, meta, path, *, line=None) -> Motion:
    """The Motion, with every complaint of its constructor turned into a FormatError naming the file."""
    if len(rotvec) == 0:
        raise FormatError("the motion has no frames", path=path, line=line)
    bad = ~np.all(np.isfinite(rotvec), axis=1)
    if bad.any():
        raise FormatError(f"{int(bad.sum())} of {len(rotvec)} frames hold NaN or inf (first: frame "
                          f"{int(np.argmax(bad))}); expected finite rotations", path=path, line=line)
    if np.abs(rotvec).max() > 1e6:
        raise FormatError(f"a rotation of {np.abs(rotvec).max():g} is not a plausible angle", path=path, line=line)
    if translation is not None:
        translation = np.asarray(translation, dtype=np.float64)
        if translation.shape != rotvec.shape:
            raise FormatError(f"'translation' has shape {translation.shape}; expected {rotvec.shape} like the "
                              f"rotations", path=path, line=line)
        if not np.all(np.isfinite(translation)):
            raise FormatError("'translation' holds NaN or inf", path=path, line=line)
    try:
        return Motion(rotvec, fps, translation=translation, meta=meta)
    except ParameterError as exc:
        raise FormatError(str(exc), path=path, line=line) from None


# -------------------------------------------------------------------------------------- JSON
def save_json(motion: Motion, path, *, degrees: bool = False, euler_order: str | None = None) -> None:
    """Write ``motion`` as JSON (see the module docstring for the layout and options)."""
    _check_motion(motion)
    values = _encode(motion, euler_order, degrees)
    doc = {"format": MAGIC, "version": VERSION, "fps": motion.fps,
           "rotation": "rotvec" if euler_order is None else "euler",
           "euler_order": euler_order, "units": "deg" if degrees else "rad",
           "columns": _columns(euler_order, degrees),
           "frames": np.round(values, 10).tolist()}
    if motion.translation is not None:
        doc["translation"] = np.asarray(motion.translation).tolist()
    doc["meta"] = _jsonable(motion.meta)
    text = json.dumps(doc, separators=(",", ":"))
    with atomic_open(path, "w", encoding="utf-8") as fh:
        fh.write(text)


def load_json(path) -> Motion:
    path = Path(path)
    doc = _load_json_bounded(read_text(path, what="JSON motion file"), path=path, what="the file")
    if not isinstance(doc, dict) or ("frames" not in doc and "rotvec" not in doc) or "fps" not in doc:
        raise FormatError("expected a headmotion motion JSON object with 'fps' and 'frames'", path=path)
    fps = check_fps(doc["fps"], path=path, what="'fps'") if not isinstance(doc["fps"], bool) else \
        check_fps(None, path=path, what="'fps'")
    meta = doc.get("meta") or {}
    if not isinstance(meta, dict):
        raise FormatError(f"'meta' must be an object; found {type(meta).__name__}", path=path)
    for key in ("rotation", "euler_order", "units"):
        if doc.get(key) is not None and not isinstance(doc[key], str):
            raise FormatError(f"'{key}' must be a string; found {doc[key]!r:.40}", path=path)
    try:
        values = np.asarray(doc.get("frames", doc.get("rotvec")), dtype=np.float64)
        tr = doc.get("translation")
        tr = None if tr is None else np.asarray(tr, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise FormatError(f"'frames' / 'translation' must be lists of [a, b, c] numbers ({exc})", path=path) from None
    if values.ndim != 2 or values.shape[1] != 3:
        raise FormatError(f"'frames' must be a list of [a, b, c] rows; found shape {values.shape}", path=path)
    if not np.all(np.isfinite(values)):
        return _motion(values, fps, tr, meta, path)  # names the NaN/inf frames
    try:
        rv = _decode(values, doc.get("rotation", "rotvec"), doc.get("euler_order"), doc.get("units") == "deg")
    except (ParameterError, ValueError) as exc:
        raise FormatError(str(exc), path=path) from None
    return _motion(rv, fps, tr, meta, path)


# --------------------------------------------------------------------------------------- CSV
def save_csv(motion: Motion, path, *, degrees: bool = False, euler_order: str | None = None) -> None:
    """Write ``motion`` as CSV (see the module docstring for the layout and options)."""
    _check_motion(motion)
    values = _encode(motion, euler_order, degrees)
    head = {"fps": motion.fps, "rotation": "rotvec" if euler_order is None else "euler",
            "euler_order": euler_order, "units": "deg" if degrees else "rad",
            "meta": _jsonable(motion.meta)}
    cols = ["frame", "time"] + _columns(euler_order, degrees)
    if motion.translation is not None:
        cols += ["tx", "ty", "tz"]
    buf = io.StringIO()
    buf.write(f"# {MAGIC} {VERSION} {json.dumps(head, separators=(',', ':'))}\n")
    buf.write(",".join(cols) + "\n")
    times = motion.times
    for t in range(len(motion)):
        row = [str(t), f"{times[t]:.6f}"] + [repr(float(v)) for v in values[t]]
        if motion.translation is not None:
            row += [repr(float(v)) for v in motion.translation[t]]
        buf.write(",".join(row) + "\n")
    with atomic_open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write(buf.getvalue())


def is_native_csv(first_lines: list[str]) -> bool:
    if first_lines and first_lines[0].startswith(f"# {MAGIC}"):
        return True
    if first_lines:
        cols = [c.strip().lower() for c in first_lines[0].split(",")]
        return {"rx", "ry", "rz"} <= set(cols) or {"pitch_deg", "yaw_deg", "roll_deg"} <= set(cols) \
            or {"pitch_rad", "yaw_rad", "roll_rad"} <= set(cols)
    return False


def load_csv(path, *, fps: float | None = None, euler_order: str | None = None) -> Motion:
    """Read a headmotion CSV (or a plain CSV with rotvec / pitch-yaw-roll columns)."""
    path = Path(path)
    if fps is not None:
        fps = check_fps(fps, what="fps=", error=ParameterError)
    text = read_text(path, what="CSV file")
    lines = text.splitlines()
    head: dict = {}
    start = 0
    if lines and lines[0].startswith("#"):
        parts = lines[0][1:].strip().split(" ", 2)
        if len(parts) == 3 and parts[0] == MAGIC:
            head = _load_json_bounded(parts[2], path=path, what="the header line's JSON")
            if not isinstance(head, dict):
                raise FormatError("the header line's JSON must be an object", path=path, line=1)
            for key in ("rotation", "euler_order", "units"):
                if head.get(key) is not None and not isinstance(head[key], str):
                    raise FormatError(f"header '{key}' must be a string", path=path, line=1)
            if head.get("meta") is not None and not isinstance(head["meta"], dict):
                raise FormatError("header 'meta' must be an object", path=path, line=1)
        start = 1
    rows = [r for _, r in csv_rows(lines[start:], path=path, first_line=start + 1)]
    if not rows:
        raise FormatError("CSV has no header row", path=path)
    cols = [c.strip().lower() for c in rows[0]]
    words = {"x": "pitch", "y": "yaw", "z": "roll"}
    rot_cols: list[int]
    units = head.get("units")
    order = head.get("euler_order") or euler_order
    rotation = head.get("rotation")
    if all(c in cols for c in ("rx", "ry", "rz")):
        rot_cols, rotation, units = [cols.index(c) for c in ("rx", "ry", "rz")], "rotvec", units or "rad"
    elif all(f"r{a}_deg" in cols for a in "xyz"):
        rot_cols, rotation, units = [cols.index(f"r{a}_deg") for a in "xyz"], "rotvec", "deg"
    else:
        unit = "deg" if "pitch_deg" in cols else "rad"
        names = [f"{w}_{unit}" for w in ("pitch", "yaw", "roll")]
        if not all(n in cols for n in names):
            raise FormatError(
                f"expected columns rx,ry,rz or pitch/yaw/roll_deg|rad; found {', '.join(rows[0][:8])}",
                path=path, line=start + 1)
        idx = sorted(cols.index(n) for n in names)
        seq = "".join({v: k for k, v in words.items()}[cols[i].rsplit("_", 1)[0]] for i in idx)
        if order is None:
            order = seq.upper()
        elif order.lower() != seq:
            raise FormatError(f"euler_order {order!r} does not match the column order {seq.upper()!r}",
                              path=path, line=start + 1)
        rot_cols, rotation, units = idx, "euler", unit
    tr_cols = [cols.index(c) for c in ("tx", "ty", "tz")] if all(c in cols for c in ("tx", "ty", "tz")) else None
    n_cols = len(cols)
    vals = []
    times = []
    t_col = cols.index("time") if "time" in cols else None
    for k, row in enumerate(rows[1:]):
        ln = start + 2 + k
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != n_cols:
            raise FormatError(f"row has {len(row)} values, expected {n_cols}", path=path, line=ln)
        try:
            r = [float(row[i]) for i in rot_cols]
            if tr_cols:
                r += [float(row[i]) for i in tr_cols]
            if t_col is not None:
                times.append(float(row[t_col]))
        except ValueError:
            raise FormatError("a value is not a number", path=path, line=ln) from None
        if not all(np.isfinite(r)):
            raise FormatError(f"a value is NaN or inf ({', '.join(row[i][:20] for i in rot_cols)}); "
                              f"expected finite numbers", path=path, line=ln)
        vals.append(r)
    if not vals:
        raise FormatError("CSV has a header but no frames", path=path)
    arr = np.array(vals)
    if fps is not None:
        rate = fps
    elif head.get("fps") is not None:
        rate = check_fps(head["fps"], path=path, line=1, what="header 'fps'")
    else:
        t = np.asarray(times, dtype=np.float64)
        d = np.diff(t[np.isfinite(t)])
        if len(d) == 0 or not np.all(d > 0):
            raise FormatError("no frame rate: no '# headmotion-motion' line and no increasing time column; "
                              "pass fps=", path=path)
        rate = check_fps(1.0 / float(np.median(d)), path=path, what="the time column's frame rate")
    if order is not None and not isinstance(order, str):
        raise FormatError("euler_order must be a string", path=path, line=1)
    try:
        rv = _decode(arr[:, :3], rotation, order, units == "deg")
    except (ParameterError, ValueError) as exc:
        raise FormatError(str(exc), path=path) from None
    return _motion(rv, rate, arr[:, 3:6] if tr_cols else None, head.get("meta") or {}, path)


__all__ = ["save_npz", "load_npz", "save_json", "load_json", "save_csv", "load_csv", "is_native_csv"]
