"""C3D motion capture files via ezc3d (thesis §3.4).

Head and torso frames are built per frame from markers (Vicon Plug-in Gait names by default):

* **Head** (``head_markers`` = LFHD, RFHD, LBHD, RBHD — left/right front/back head):
  forward ``f = mean(LFHD, RFHD) − mean(LBHD, RBHD)``, left ``l = mean(LFHD, LBHD) −
  mean(RFHD, RBHD)``.  ``z = f/|f|``; ``x`` = ``l`` with its ``z`` component removed, normalised;
  ``y = z × x`` (up).
* **Torso** (``torso_markers`` = C7, T10, CLAV, STRN): up ``u = mean(C7, CLAV) − mean(T10,
  STRN)``, forward ``f = mean(CLAV, STRN) − mean(C7, T10)``.  ``y = u/|u|``; ``z`` = ``f`` with
  its ``y`` component removed, normalised; ``x = y × z`` (left).

Each basis ``B = [x y z]`` (columns, lab coordinates) already has our axes (+x the subject's left,
+y up, +z forward; :mod:`headmotion.rotations`), so whatever the lab's axes (C3D labs are usually
Z-up) the head relative to the torso is ``R = B_torso^T B_head``.  The Plug-in Gait head markers
sit on a plane tilted against the torso, so the rest pose has a constant pitch offset (about
10–20°); ``center=True`` removes the mean rotation (``R_mean^T R``) if a zero-mean signal is wanted.
Translation: head-marker centroid minus torso-marker centroid in the torso frame, metres, mean
reset to zero.  Missing markers (NaN, or negative residual) leave gaps filled as for OptiTrack.

Libraries considered: ezc3d (used; maintained, wheels on PyPI), ``c3d`` (pure Python, slower).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import FormatError, MissingDependencyError, NoHeadError
from ..types import Motion
from ._limits import check_fps
from ._mocap import fill_gaps

HEAD_MARKERS = ("LFHD", "RFHD", "LBHD", "RBHD")
TORSO_MARKERS = ("C7", "T10", "CLAV", "STRN")
_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}


def _read(path):
    try:
        import ezc3d
    except ImportError:  # pragma: no cover
        raise MissingDependencyError("reading C3D files needs ezc3d: pip install ezc3d") from None
    path = Path(path)
    if not path.is_file():
        raise FormatError("file not found", path=path)
    if path.stat().st_size == 0:
        raise FormatError("file is empty (expected a C3D file)", path=path)
    check_header(path)  # declared sizes against the file's length before ezc3d allocates
    try:
        c = ezc3d.c3d(str(path))
    except Exception as exc:  # ezc3d raises RuntimeError/IOError on bad files
        raise FormatError(f"not a readable C3D file ({exc})", path=path) from None
    try:
        p = c["parameters"]["POINT"]
        labels = [str(s).strip() for s in p["LABELS"]["value"]] if "LABELS" in p else []
        pts = np.array(c["data"]["points"][:3], dtype=np.float64)  # (3, N, T)
        if "residuals" in c["data"]["meta_points"]:
            res = np.asarray(c["data"]["meta_points"]["residuals"])  # (1, N, T)
            if res.shape[1:] == pts.shape[1:]:
                pts[:, res[0] < 0] = np.nan
        rate_v = np.ravel(p["RATE"]["value"]) if "RATE" in p else []
        rate = rate_v[0] if len(rate_v) else c["header"]["points"]["frame_rate"]
        unit_v = list(p["UNITS"]["value"]) if "UNITS" in p else []
    except (KeyError, IndexError, TypeError, ValueError) as exc:
        raise FormatError(f"the C3D POINT parameters are damaged ({type(exc).__name__}: {exc})", path=path) from None
    rate = check_fps(rate, path=path, what="POINT:RATE")
    if pts.ndim != 3 or pts.shape[1] == 0 or pts.shape[2] == 0:
        raise FormatError(f"the C3D file holds no 3-D points (points array {pts.shape})", path=path)
    if len(labels) < pts.shape[1]:
        labels = labels + [f"*{k}" for k in range(len(labels), pts.shape[1])]
    labels = labels[:pts.shape[1]]
    pts[~np.isfinite(pts)] = np.nan
    with np.errstate(invalid="ignore"):
        pts[np.abs(pts) > 1e9] = np.nan  # damaged values are gaps
    units = str(unit_v[0]).strip().lower() if unit_v else "mm"
    return c, labels, pts.transpose(2, 1, 0), rate, _UNITS.get(units, 1e-3)


def check_header(path: Path) -> None:
    """Check the 512-byte C3D header (Motion Lab Systems' C3D manual, "The header section"):
    the parameter-block pointer and key byte, the point and analog counts and the frame range,
    and that the data they declare fits in the file.  ezc3d trusts these numbers."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(512)
        if len(head) < 512:
            raise FormatError(f"file is {len(head)} bytes; a C3D file starts with a 512-byte header", path=path)
        if head[1] != 0x50:
            raise FormatError(f"byte 2 is {head[1]:#x}, not 0x50: not a C3D file", path=path)
        param_block = head[0]
        if param_block < 2 or (param_block - 1) * 512 + 4 > size:
            raise FormatError(f"the header points to a parameter section at block {param_block}, "
                              f"outside the file ({size} bytes)", path=path)
        fh.seek((param_block - 1) * 512)
        phead = fh.read(4)
    proc = phead[3] - 83 if len(phead) == 4 else 1  # 1 Intel, 2 DEC, 3 MIPS (big-endian)
    if proc not in (1, 2, 3):
        raise FormatError(f"unknown processor type {phead[3] if len(phead) == 4 else '?'} in the parameter "
                          f"section (expected 84, 85 or 86)", path=path)
    endian = ">" if proc == 3 else "<"
    words = np.frombuffer(head[:24], dtype=endian + "u2")
    n_points, n_analog, first, last = (int(w) for w in words[1:5])
    data_block = int(words[8])
    scale_bytes = head[12:16]
    negative = (scale_bytes[0] if proc == 3 else scale_bytes[1] if proc == 2 else scale_bytes[3]) & 0x80
    value_bytes = 4 if negative else 2
    if last < first:
        raise FormatError(f"the header's frame range {first}–{last} is empty", path=path)
    n_frames = last - first + 1
    if data_block < 2:
        raise FormatError(f"the header's data-block pointer {data_block} is invalid", path=path)
    need = (data_block - 1) * 512 + n_frames * (n_points * 4 + n_analog) * value_bytes
    if need > size:
        raise FormatError(f"the header declares {n_frames} frames of {n_points} points and {n_analog} analog "
                          f"values ({need} bytes) but the file holds {size} bytes (truncated?)", path=path)
    with open(path, "rb") as fh:
        fh.seek((param_block - 1) * 512)
        params = fh.read((data_block - param_block) * 512 if data_block > param_block else 512 * 255)
    _check_parameter_chain(params, endian, path)


def _check_parameter_chain(buf: bytes, endian: str, path: Path) -> None:
    """Walk the parameter section's records (each names the offset of the next) and check that
    every record and its data lie inside the section and that the chain moves forward, so that a
    damaged section is an error here instead of a hang in the C++ reader."""
    if len(buf) < 4:
        raise FormatError("the parameter section is cut short", path=path)
    n_blocks = buf[2]
    end = min(len(buf), max(n_blocks, 1) * 512)
    pos = 4
    while pos + 2 <= end:
        n = int.from_bytes(buf[pos:pos + 1], "little", signed=True)
        if n == 0:
            return
        gid = int.from_bytes(buf[pos + 1:pos + 2], "little", signed=True)
        off_at = pos + 2 + abs(n)
        if off_at + 2 > end:
            raise FormatError(f"a parameter record at byte {pos} runs past the parameter section", path=path)
        off = int.from_bytes(buf[off_at:off_at + 2], "big" if endian == ">" else "little", signed=True)
        nxt = off_at + off if off != 0 else end
        if off != 0 and not (off_at < nxt <= end):
            raise FormatError(f"a parameter record at byte {pos} points to byte {nxt}, outside the parameter "
                              f"section ({end} bytes)", path=path)
        if gid > 0:  # a parameter: type, dimensions and data must fit before the next record
            q = off_at + 2
            if q + 2 > nxt:
                raise FormatError(f"parameter record at byte {pos} is cut short", path=path)
            kind = int.from_bytes(buf[q:q + 1], "little", signed=True)
            ndim = buf[q + 1]
            if kind not in (-1, 1, 2, 4) or q + 2 + ndim > nxt:
                raise FormatError(f"parameter record at byte {pos} has type {kind} and {ndim} dimensions; "
                                  f"expected type -1, 1, 2 or 4", path=path)
            count = 1
            for d in buf[q + 2:q + 2 + ndim]:
                count *= d
            if q + 2 + ndim + abs(kind) * count > nxt:
                raise FormatError(f"parameter record at byte {pos} declares {abs(kind) * count} bytes of data "
                                  f"that do not fit before the next record", path=path)
            _check_description(buf, q + 2 + ndim + abs(kind) * count, nxt, pos, path)
        elif off != 0:  # a group: its description must fit before the next record
            _check_description(buf, off_at + 2, nxt, pos, path)
        if off == 0:
            return
        pos = nxt
    raise FormatError("the parameter section has no end record", path=path)


def _check_description(buf: bytes, at: int, nxt: int, pos: int, path: Path) -> None:
    """A record's description (a length byte, then that many characters) must end before the
    next record (ezc3d reads past the record otherwise — a segmentation fault found by fuzzing)."""
    if at + 1 > nxt or at + 1 + buf[at] > nxt:
        n = buf[at] if at < len(buf) else 0
        raise FormatError(f"the record at byte {pos} of the parameter section has a description of {n} "
                          f"bytes that does not fit before the next record (byte {nxt})", path=path)


def _get(labels, pts, names, what, path):
    low = [s.upper() for s in labels]
    missing = [n for n in names if n.upper() not in low]
    if missing:
        markers = [s for s in labels if not s.startswith("*")]
        raise NoHeadError(f"{what} markers {', '.join(missing)} not in the file; markers that exist: "
                          f"{', '.join(markers)}; pass {what}_markers=[...]", path=path)
    return [pts[:, low.index(n.upper())] for n in names]


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _gram_schmidt(a, b):
    """Unit ``a``, unit ``b`` made orthogonal to it, and their cross product: a right-handed frame."""
    ea = _unit(a)
    eb = _unit(b - np.sum(b * ea, -1, keepdims=True) * ea)
    return ea, eb, np.cross(ea, eb)


def head_basis(lfhd, rfhd, lbhd, rbhd) -> np.ndarray:
    """``(T, 3, 3)`` head frames, columns x (left), y (up), z (forward) in lab coordinates: z along
    back-to-front, x along right-to-left made orthogonal to it."""
    z, x, y = _gram_schmidt((lfhd + rfhd) / 2 - (lbhd + rbhd) / 2, (lfhd + lbhd) / 2 - (rfhd + rbhd) / 2)
    return np.stack([x, y, z], axis=-1)


def torso_basis(c7, t10, clav, strn) -> np.ndarray:
    """``(T, 3, 3)`` torso frames, columns x (left), y (up), z (forward) in lab coordinates: y along
    bottom-to-top, z along back-to-front made orthogonal to it."""
    y, z, x = _gram_schmidt((c7 + clav) / 2 - (t10 + strn) / 2, (clav + strn) / 2 - (c7 + t10) / 2)
    return np.stack([x, y, z], axis=-1)


def load_c3d(path, *, head_markers=HEAD_MARKERS, torso_markers=TORSO_MARKERS, max_gap: float = 0.1,
             center: bool = False) -> Motion:
    """Head rotation relative to the torso from a C3D file (see the module docstring).

    Parameters
    ----------
    head_markers : 4 names, order left-front, right-front, left-back, right-back
    torso_markers : 4 names, order C7, T10, CLAV, STRN (back-top, back-low, front-top, front-low)
    max_gap : float, seconds interpolated without a warning
    center : bool, remove the mean rotation

    Returns
    -------
    Motion with ``rotvec (T, 3)``, ``translation (T, 3)`` metres, at the C3D point rate.
    """
    path = Path(path)
    if len(head_markers) != 4 or len(torso_markers) != 4:
        from ..errors import ParameterError

        raise ParameterError(f"head_markers and torso_markers need 4 names each; got {list(head_markers)} "
                             f"and {list(torso_markers)}")
    _, labels, pts, rate, scale = _read(path)
    h = _get(labels, pts, head_markers, "head", path)
    b = _get(labels, pts, torso_markers, "torso", path)
    with np.errstate(invalid="ignore", divide="ignore"):
        bh = head_basis(*h)
        bt = torso_basis(*b)
        rel = np.einsum("tji,tjk->tik", bt, bh)
        pos = np.einsum("tji,tj->ti", bt, np.mean(h, 0) - np.mean(b, 0)) * scale
    T = len(rel)
    bad = ~np.all(np.isfinite(rel.reshape(T, 9)), 1) | ~np.all(np.isfinite(pos), 1)
    if bad.all():
        raise NoHeadError("the head or torso markers are missing in every frame", path=path)
    rv = np.full((T, 3), np.nan)
    rv[~bad] = Rotation.from_matrix(rel[~bad]).as_rotvec()
    pos[bad] = np.nan
    filled, report = fill_gaps(np.hstack([rv, pos]), fps=rate, max_gap=max_gap, path=path)
    rv, tr = filled[:, :3], filled[:, 3:]
    if center:
        r = Rotation.from_rotvec(rv)
        rv = (r.mean().inv() * r).as_rotvec()
    meta = {"source": str(path), "format": "c3d", "head_markers": list(head_markers),
            "torso_markers": list(torso_markers), "relative_to": "torso_markers", "gaps": report,
            "centered": bool(center)}
    return Motion(rv, rate, translation=tr - tr.mean(0), meta=meta)


def c3d_info(path) -> dict:
    c, labels, pts, rate, _ = _read(path)
    return {"format": "c3d", "n_frames": int(pts.shape[0]), "fps": rate, "duration": pts.shape[0] / rate,
            "markers": labels, "n_markers": len(labels)}


__all__ = ["load_c3d", "c3d_info", "head_basis", "torso_basis", "HEAD_MARKERS", "TORSO_MARKERS"]
