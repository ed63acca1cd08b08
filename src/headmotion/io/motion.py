"""Load and save head motion in any supported format (docs/design.md "Data flows one way"; thesis
§2.2.3, §3.4).

:func:`load_motion` picks the reader from ``format=`` or the extension; a ``.csv`` is sniffed
from its first lines: ``Format Version`` → OptiTrack Motive, ``Timecode``…``HeadYaw`` → Live Link
Face, ``pose_Rx`` → OpenFace, ``# headmotion-motion`` or ``rx,ry,rz`` columns → native; a ``.npz``
from its array names: ``poses`` / ``pose_body`` (no ``rotvec``) → SMPL, else native.
:func:`save_motion` writes ``bvh``, ``csv``, ``json``, ``npz``, ``glb``/``gltf`` (by extension) or
``livelink`` (``format="livelink"``).  Every reader maps the file's axes onto the one convention of
:mod:`headmotion.rotations`; see each module's docstring for how.

========== ===================== ============================== =======
format     extensions            module                         write
========== ===================== ============================== =======
bvh        .bvh                  :mod:`headmotion.io.bvh`       yes
optitrack  .csv (sniffed)        :mod:`headmotion.io.optitrack` no
c3d        .c3d                  :mod:`headmotion.io.c3d`       no
openface   .csv (sniffed)        :mod:`headmotion.io.openface`  no
livelink   .csv (sniffed)        :mod:`headmotion.io.livelink`  yes
smpl       .npz (sniffed)        :mod:`headmotion.io.smpl`      no
csv        .csv                  :mod:`headmotion.io.native`    yes
json       .json                 :mod:`headmotion.io.native`    yes
npz        .npz                  :mod:`headmotion.io.native`    yes
gltf       .glb, .gltf           :mod:`headmotion.io.gltf`      only
========== ===================== ============================== =======

Errors: a missing, empty or directory path, an unknown extension or an unrecognised CSV raise
:class:`~headmotion.errors.FormatError` naming the file; readers add the line where known and
:class:`~headmotion.errors.NoHeadError` when no head joint / markers / rigid body is found.

Libraries considered: pymo / bvhio / ezc3d / py-feat each read one format into their own
types; only ezc3d is used (for C3D) — the dispatch and the axis mapping are ours.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import FormatError, ParameterError
from ..types import Motion
from ._limits import check_file

READ_FORMATS = ("bvh", "optitrack", "c3d", "openface", "livelink", "smpl", "csv", "json", "npz", "gltf")
WRITE_FORMATS = ("bvh", "csv", "json", "npz", "livelink", "gltf")
_EXT = {".bvh": "bvh", ".c3d": "c3d", ".json": "json", ".npz": "npz", ".csv": "csv", ".glb": "gltf", ".gltf": "gltf"}
_ALIASES = {"motive": "optitrack", "live-link": "livelink", "live_link": "livelink", "native": "csv",
            "smplx": "smpl", "smpl-x": "smpl", "smplh": "smpl", "smpl-h": "smpl"}


def _norm_format(fmt: str, allowed) -> str:
    f = _ALIASES.get(str(fmt).lower(), str(fmt).lower())
    if f not in allowed:
        raise ParameterError(f"unknown motion format {fmt!r}; expected one of {', '.join(allowed)}")
    return f


def sniff_csv(path) -> str:
    """Which kind of CSV ``path`` is: ``optitrack``, ``livelink``, ``openface`` or ``csv``."""
    from .native import is_native_csv

    with open(path, encoding="utf-8-sig", errors="replace") as fh:
        head = [fh.readline() for _ in range(3)]
    first = head[0].strip()
    if first.startswith("Format Version"):
        return "optitrack"
    if "Timecode" in first and "HeadYaw" in first:
        return "livelink"
    cols = {c.strip() for c in first.split(",")}
    if {"pose_Rx", "pose_Ry", "pose_Rz"} <= cols:
        return "openface"
    if is_native_csv([h.rstrip("\n") for h in head]) or (first.startswith("#") and is_native_csv(head[1:2])):
        return "csv"
    raise FormatError(
        f"unrecognised CSV: the first line {first[:60]!r} is not an OptiTrack Motive, Live Link Face, "
        f"OpenFace or headmotion CSV header; pass format=", path=path, line=1)


def sniff_npz(path) -> str:
    """Which kind of ``.npz`` ``path`` is: ``smpl`` (SMPL-family parameters) or ``npz`` (ours)."""
    import zipfile

    from .smpl import is_smpl_npz

    try:
        with zipfile.ZipFile(path) as zf:
            names = [n[:-4] if n.endswith(".npy") else n for n in zf.namelist()]
    except (zipfile.BadZipFile, OSError) as exc:
        raise FormatError(f"not a readable .npz file ({exc})", path=path) from None
    return "smpl" if is_smpl_npz(names) else "npz"


def detect_format(path) -> str:
    """The reader for ``path`` from its extension (and, for ``.csv``, its header)."""
    p = Path(path)
    ext = p.suffix.lower()
    if ext not in _EXT:
        raise FormatError(f"unknown motion file extension {ext or '(none)'!r}; supported: "
                          f"{', '.join(sorted(_EXT))}", path=p)
    fmt = _EXT[ext]
    if fmt == "csv":
        fmt = sniff_csv(p)
    elif fmt == "npz":
        fmt = sniff_npz(p)
    return fmt


def load_motion(path, *, format: str | None = None, **options) -> Motion:
    """Read head motion from ``path``.

    Parameters
    ----------
    path : str or Path
    format : str, optional
        One of ``bvh, optitrack, c3d, openface, livelink, smpl, csv, json, npz, gltf``; from the
        extension (and a CSV's header or an npz's arrays) when omitted.
    **options
        Passed to the reader, e.g. ``head="Head"``, ``relative_to="Spine2"`` (BVH),
        ``head_markers=[...]``, ``body_markers=[...]``, ``max_gap=0.1`` (OptiTrack, C3D),
        ``fps=`` (OpenFace, Live Link, SMPL, plain CSV).

    Returns
    -------
    Motion, ``rotvec (T, 3)`` radians in the convention of :mod:`headmotion.rotations`.
    """
    p = check_file(path, expected="a motion file")
    fmt = detect_format(p) if format is None else _norm_format(format, READ_FORMATS)
    try:
        if fmt == "bvh":
            from .bvh import load_bvh as fn
        elif fmt == "optitrack":
            from .optitrack import load_optitrack as fn
        elif fmt == "c3d":
            from .c3d import load_c3d as fn
        elif fmt == "openface":
            from .openface import load_openface as fn
        elif fmt == "livelink":
            from .livelink import load_livelink as fn
        elif fmt == "smpl":
            from .smpl import load_smpl as fn
        elif fmt == "gltf":  # what save_gltf writes (headmotion synth -o head.glb)
            from .gltf import load_gltf as fn
        elif fmt == "csv":
            from .native import load_csv as fn
        elif fmt == "json":
            from .native import load_json as fn
        else:
            from .native import load_npz as fn
        return fn(p, **options)
    except TypeError as exc:
        if "unexpected keyword" in str(exc):
            raise ParameterError(f"{p}: option not understood by the {fmt} reader: {exc}") from None
        raise
    except UnicodeDecodeError as exc:
        raise FormatError(f"not a text {fmt} file ({exc.reason})", path=p) from None


def save_motion(motion: Motion, path, *, format: str | None = None, **options) -> None:
    """Write ``motion`` to ``path`` atomically (no partial file on failure).

    Parameters
    ----------
    motion : Motion
    path : str or Path
    format : str, optional
        ``bvh, csv, json, npz, livelink``; from the extension when omitted.
    **options
        ``channel_order="ZXY"|"YXZ"``, ``neck_share`` (BVH, glTF); ``degrees=True``,
        ``euler_order="YXZ"`` (CSV, JSON).
    """
    if not isinstance(motion, Motion):
        raise ParameterError(f"save_motion needs a Motion; got {type(motion).__name__}")
    p = Path(path)
    if len(motion) == 0:  # no format's reader takes a file without frames
        raise ParameterError(f"{p}: cannot write a motion with zero frames")
    if format is None:
        ext = p.suffix.lower()
        if ext not in (".bvh", ".csv", ".json", ".npz", ".glb", ".gltf"):
            raise FormatError(f"unknown extension {ext or '(none)'!r} for writing motion; supported: "
                              f".bvh, .csv, .json, .npz, .glb, .gltf (and format='livelink')", path=p)
        fmt = "gltf" if ext in (".glb", ".gltf") else ext[1:]
    else:
        fmt = _norm_format(format, WRITE_FORMATS)
    try:
        if fmt == "bvh":
            from .bvh import save_bvh

            save_bvh(motion, p, **options)
        elif fmt == "livelink":
            from .livelink import save_livelink

            save_livelink(motion, p, **options)
        elif fmt == "gltf":
            from .gltf import save_gltf

            save_gltf(motion, p, **options)
        elif fmt == "csv":
            from .native import save_csv

            save_csv(motion, p, **options)
        elif fmt == "json":
            from .native import save_json

            save_json(motion, p, **options)
        else:
            from .native import save_npz

            if options:
                raise ParameterError(f"the npz writer takes no options; got {sorted(options)}")
            save_npz(motion, p)
    except TypeError as exc:
        if "unexpected keyword" in str(exc):
            raise ParameterError(f"option not understood by the {fmt} writer: {exc}") from None
        raise


def motion_info(path) -> dict:
    """What a motion file holds: format, frames, fps, duration, joints/markers, head SD (deg)."""
    p = check_file(path, expected="a motion file")
    fmt = detect_format(p)
    info: dict = {"path": str(p), "format": fmt}
    if fmt == "bvh":
        from .bvh import bvh_info

        info.update(bvh_info(p))
    elif fmt == "optitrack":
        from .optitrack import optitrack_info

        info.update(optitrack_info(p))
    elif fmt == "c3d":
        from .c3d import c3d_info

        info.update(c3d_info(p))
    try:
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = load_motion(p, format=fmt)
    except FormatError as exc:  # e.g. a BVH without a head: still describe the file
        info["head_motion"] = f"unavailable: {exc}"
        return info
    info.setdefault("n_frames", len(m))
    info.setdefault("fps", m.fps)
    info.setdefault("duration", m.duration)
    info["sd_deg"] = dict(zip(("pitch", "yaw", "roll"), np.degrees(m.rotvec.std(axis=0)).round(3).tolist()))
    for k in ("head_joint", "relative_to", "head", "head_markers", "fallback", "layout", "model"):
        if k in m.meta and k not in info:
            info[k] = m.meta[k]
    gaps = m.meta.get("gaps")
    if gaps:
        info["gaps"] = {"filled_frames": gaps["filled_frames"], "long_gaps": len(gaps["long_gaps"])}
    return info


__all__ = ["load_motion", "save_motion", "motion_info", "detect_format", "sniff_csv", "sniff_npz",
           "READ_FORMATS", "WRITE_FORMATS"]
