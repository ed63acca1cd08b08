"""Live Link Face CSV (Epic's iPhone app).

Layout: ``Timecode,BlendShapeCount,<52 ARKit blend shapes>,HeadYaw,HeadPitch,HeadRoll,
LeftEyeYaw,LeftEyePitch,LeftEyeRoll,RightEyeYaw,RightEyePitch,RightEyeRoll`` (63 columns, 61
counted by ``BlendShapeCount``), one row per frame, ``Timecode`` = ``HH:MM:SS:FF.fff`` (FF the
frame within the second, ``.fff`` a sub-frame fraction).

Axes.  ARKit's face frame is right-handed with +x the face's left, +y up, +z out of the face —
our convention (:mod:`headmotion.rotations`).  ``HeadYaw``/``HeadPitch``/``HeadRoll`` are read as
radians about our y / x / z, applied yaw → pitch → roll (intrinsic ``"YXZ"``,
:func:`headmotion.rotations.pitch_yaw_roll_to_rotvec`).  The signs follow our convention; they
could not be checked against a recording with head motion (the sample file we have holds zeros
in the head columns), so treat them as documented but unverified against the app.

The frame rate is given by ``fps=`` or inferred from the largest ``FF`` in the timecodes (snapped
to 24, 25, 30, 48, 50, 60 or 120).  The writer produces the same 63 columns with blend shapes and
eye angles at 0, ``BlendShapeCount`` = 61 and a timecode from the frame index and ``fps``.

Libraries considered: none (Epic's importer is inside Unreal; the format is a plain CSV).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..errors import FormatError, ParameterError
from ..rotations import pitch_yaw_roll_to_rotvec, rotvec_to_pitch_yaw_roll
from ..types import Motion
from ._limits import check_fps, check_size, csv_rows
from .atomic import atomic_open

BLENDSHAPES = (
    "EyeBlinkLeft EyeLookDownLeft EyeLookInLeft EyeLookOutLeft EyeLookUpLeft EyeSquintLeft EyeWideLeft "
    "EyeBlinkRight EyeLookDownRight EyeLookInRight EyeLookOutRight EyeLookUpRight EyeSquintRight EyeWideRight "
    "JawForward JawRight JawLeft JawOpen MouthClose MouthFunnel MouthPucker MouthRight MouthLeft "
    "MouthSmileLeft MouthSmileRight MouthFrownLeft MouthFrownRight MouthDimpleLeft MouthDimpleRight "
    "MouthStretchLeft MouthStretchRight MouthRollLower MouthRollUpper MouthShrugLower MouthShrugUpper "
    "MouthPressLeft MouthPressRight MouthLowerDownLeft MouthLowerDownRight MouthUpperUpLeft MouthUpperUpRight "
    "BrowDownLeft BrowDownRight BrowInnerUp BrowOuterUpLeft BrowOuterUpRight CheekPuff CheekSquintLeft "
    "CheekSquintRight NoseSneerLeft NoseSneerRight TongueOut"
).split()
HEAD = ("HeadYaw", "HeadPitch", "HeadRoll")
EYES = ("LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll", "RightEyeYaw", "RightEyePitch", "RightEyeRoll")
COLUMNS = ("Timecode", "BlendShapeCount", *BLENDSHAPES, *HEAD, *EYES)
_RATES = (24, 25, 30, 48, 50, 60, 120)


def _parse_tc(tc: str, path, ln) -> tuple[int, int, int, int, float]:
    try:
        hh, mm, ss, ff = tc.strip().split(":")
        f, _, sub = ff.partition(".")
        parts = (hh, mm, ss, f)
        if not all(p.isdigit() and len(p) <= 4 for p in parts) or (sub and not (sub.isdigit() and len(sub) <= 9)):
            raise ValueError(tc)
        return int(hh), int(mm), int(ss), int(f), float("0." + sub) if sub else 0.0
    except ValueError:
        raise FormatError(f"Timecode {tc!r} is not HH:MM:SS:FF.fff", path=path, line=ln) from None


def load_livelink(path, *, fps: float | None = None) -> Motion:
    """Head rotation from a Live Link Face CSV (see the module docstring for axes and units)."""
    path = Path(path)
    check_size(path, what="Live Link Face CSV")
    if fps is not None:
        fps = check_fps(fps, what="fps=", error=ParameterError)
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = [r for _, r in csv_rows(fh, path=path)]
    except (OSError, UnicodeDecodeError) as exc:
        raise FormatError(f"cannot read Live Link Face CSV ({exc})", path=path) from None
    if not rows:
        raise FormatError("file is empty (expected a Live Link Face CSV)", path=path)
    cols = [c.strip() for c in rows[0]]
    missing = [c for c in ("Timecode", *HEAD) if c not in cols]
    if missing:
        raise FormatError(f"not a Live Link Face CSV: columns {', '.join(missing)} missing", path=path, line=1)
    ix = [cols.index(c) for c in HEAD]
    vals, tcs = [], []
    for k, row in enumerate(rows[1:]):
        ln = k + 2
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(cols):
            raise FormatError(f"row has {len(row)} values, expected {len(cols)}", path=path, line=ln)
        try:
            v = [float(row[i]) for i in ix]
        except ValueError:
            raise FormatError(f"a head value ({', '.join(row[i][:20] for i in ix)}) is not a number",
                              path=path, line=ln) from None
        if not all(np.isfinite(v)) or max(abs(x) for x in v) > 100.0:
            raise FormatError(f"head angles {', '.join(row[i][:20] for i in ix)} are not finite angles "
                              f"in radians (expected |angle| <= 100)", path=path, line=ln)
        vals.append(v)
        tcs.append(_parse_tc(row[0], path, ln))
    if not vals:
        raise FormatError("Live Link Face CSV has a header but no frames", path=path)
    if fps is None:
        top = max(t[3] for t in tcs) + 1
        fps = float(min(_RATES, key=lambda r: (r < top, abs(r - top))))
    v = np.array(vals)  # yaw, pitch, roll
    rv = pitch_yaw_roll_to_rotvec(v[:, 1], v[:, 0], v[:, 2])
    meta = {"source": str(path), "format": "livelink", "relative_to": "camera",
            "start_timecode": rows[1][0].strip()}
    return Motion(rv, fps, meta=meta)


def _timecode(i: int, fps: float) -> str:
    n = int(round(fps))
    s, f = divmod(i, n)
    m, s = divmod(s, 60)
    h, m = divmod(m, 60)
    return f"{h:02d}:{m:02d}:{s:02d}:{f:02d}.000"


def save_livelink(motion: Motion, path) -> None:
    """Write ``motion`` as a Live Link Face CSV (63 columns; head angles in radians)."""
    if not isinstance(motion, Motion):
        raise ParameterError(f"expected a Motion; got {type(motion).__name__}")
    if abs(motion.fps - round(motion.fps)) > 1e-6:
        raise ParameterError(f"Live Link Face timecodes need a whole-number frame rate; got {motion.fps}")
    pyr = rotvec_to_pitch_yaw_roll(motion.rotvec)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    zeros = ["0.0000000000"] * len(BLENDSHAPES)
    eyes = ["0.0000000000"] * len(EYES)
    for t in range(len(motion)):
        p, y, r = pyr[t]
        w.writerow([_timecode(t, motion.fps), str(len(BLENDSHAPES) + len(HEAD) + len(EYES)), *zeros,
                    f"{y:.10f}", f"{p:.10f}", f"{r:.10f}", *eyes])
    with atomic_open(path, "w", encoding="utf-8", newline="") as fh:
        fh.write(buf.getvalue())


__all__ = ["load_livelink", "save_livelink", "COLUMNS"]
