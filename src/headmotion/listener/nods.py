"""Nods cut from recorded head motion: the back-channel nods of a listening head are recorded
movements, never drawn curves.

The recorded motion is the library a motion-matching model holds (``lib_motion_``: pitch, yaw,
roll in degrees about the training mean pose, one recording after another, ``lib_lengths_``
frames each, at ``fps_``); :func:`recorded_motion` is the one accessor, and a model without such a
library lends the shipped streaming model's.  :func:`find_nods` finds nods by the shape of the
pitch velocity (positive pitch turns the nose down, :mod:`headmotion.rotations`): a downward
stroke (velocity above ``min_speed``) followed within ``max_gap_s`` by an upward one (below
``-min_speed``), from where the head starts down to where it stops coming up, the head moving
``min_depth``–``max_depth`` degrees down and coming back at least half-way, yaw and roll moving
less than ``max_side`` of the pitch's travel.  Each nod is kept as its movement relative to its
first frame with the straight line between its ends taken out, so it starts and ends at zero and
can be added to any pose (:class:`NodBank`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def recorded_motion(model) -> tuple[list[np.ndarray], float]:
    """(recordings as ``(n, 3)`` degrees of pitch, yaw, roll; their frame rate) of the recorded
    motion ``model`` holds — the shipped streaming model's when ``model`` holds none."""
    lib = getattr(model, "lib_motion_", None)
    if lib is None:
        from ..systems.base import load_model

        model = load_model("stream")
        lib = model.lib_motion_
    lengths = np.asarray(model.lib_lengths_, dtype=np.int64)
    cut = np.cumsum(lengths)[:-1]
    return np.split(np.asarray(lib, dtype=np.float64), cut), float(model.fps_)


@dataclass(frozen=True)
class NodShape:
    """What counts as a nod (degrees, seconds)."""

    min_speed: float = 12.0     # °/s of pitch in each stroke
    max_gap_s: float = 0.40     # from the down stroke's peak to the up stroke's
    min_depth: float = 1.5      # ° the head goes down
    max_depth: float = 12.0
    min_return: float = 0.5     # share of the depth the head comes back up
    max_side: float = 0.7       # yaw and roll travel over the pitch's
    min_s: float = 0.24
    max_s: float = 1.2


def find_nods(x: np.ndarray, fps: float, shape: NodShape | None = None) -> list[tuple[int, int]]:
    """``[(a, b), ...]``: frames ``a … b-1`` of ``x (n, 3)`` (degrees) that hold a recorded nod."""
    s = shape or NodShape()
    p = np.asarray(x, dtype=np.float64)[:, 0]
    if len(p) < 4:
        return []
    v = np.diff(p) * fps  # v[i]: from frame i to i + 1
    out, i, n = [], 1, len(v)
    gap = int(round(s.max_gap_s * fps))
    while i < n - 1:
        if not (v[i] > s.min_speed and v[i] >= v[i - 1] and v[i] >= v[i + 1]):
            i += 1
            continue
        j = next((k for k in range(i + 1, min(n, i + gap + 1)) if v[k] < -s.min_speed), None)
        if j is None:
            i += 1
            continue
        while j + 1 < n and v[j + 1] < v[j]:  # to the up stroke's peak
            j += 1
        a = i
        while a > 0 and v[a - 1] > 0:  # back to where the head started down
            a -= 1
        b = j + 1
        while b < n and v[b] < 0:  # on to where it stops coming up
            b += 1
        seg = x[a:b + 1]
        depth = float(seg[:, 0].max() - seg[0, 0])
        back = float(seg[:, 0].max() - seg[-1, 0])
        side = float(np.ptp(seg[:, 1:], axis=0).max())
        dur = (b + 1 - a) / fps
        if (s.min_depth <= depth <= s.max_depth and back >= s.min_return * depth and side <= s.max_side * depth
                and s.min_s <= dur <= s.max_s):
            out.append((a, b + 1))
            i = b + 1
        else:
            i += 1
    return out


def nod_curve(seg: np.ndarray) -> np.ndarray:
    """A recorded nod as a movement: relative to its first frame, the straight line between its
    ends taken out (it starts and ends at 0)."""
    d = np.asarray(seg, dtype=np.float64) - seg[0]
    ramp = np.linspace(0.0, 1.0, len(d))[:, None]
    return d - ramp * d[-1]


class NodBank:
    """The recorded nods of a model's library, as movements in degrees at its frame rate.

    ``nods``: list of ``(n_k, 3)`` curves; ``source``: ``(recording, first frame)`` of each."""

    def __init__(self, curves: list[np.ndarray], fps: float, source: list[tuple[int, int]]):
        self.nods, self.fps, self.source = curves, float(fps), source

    @classmethod
    def from_model(cls, model, shape: NodShape | None = None) -> "NodBank":
        recs, fps = recorded_motion(model)
        curves, source = [], []
        for r, x in enumerate(recs):
            for a, b in find_nods(x, fps, shape):
                curves.append(nod_curve(x[a:b]))
                source.append((r, a))
        return cls(curves, fps, source)

    def __len__(self) -> int:
        return len(self.nods)

    def depths(self) -> np.ndarray:
        """How far each nod goes down (degrees of pitch)."""
        return np.array([c[:, 0].max() for c in self.nods])


_BANKS: dict[int, NodBank] = {}


def nod_bank(model) -> NodBank:
    """The model's :class:`NodBank`, found once per loaded model (the library is read-only)."""
    key = id(getattr(model, "lib_motion_", None))
    bank = _BANKS.get(key)
    if bank is None:
        bank = _BANKS[key] = NodBank.from_model(model)
    return bank


__all__ = ["NodShape", "NodBank", "find_nods", "nod_curve", "nod_bank", "recorded_motion"]
