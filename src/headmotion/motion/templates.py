"""Motion templates and warping: encode a trajectory to warping parameters and back
(thesis §5.1, §5.3 eq 5.1–5.2, Table 5.1; §5.4 "offset from continuity").

Two templates are used for every axis, a rising and a falling half-cosine (eq 5.1, 5.2)::

    g1(t; d, a, c) = -a/2 cos(pi t / d) + (2c + a)/2      (rising from c to c + a)
    g2(t; d, a, c) =  a/2 cos(pi t / d) + (2c - a)/2      (falling from c to c - a)

with duration ``d`` (frames or seconds), amplitude ``a >= 0`` and offset ``c`` (the start value).
Both are ``c + s (1 - cos(pi t / d)) / 2`` with the *signed* amplitude ``s = ±a``; the code uses
that form.  Consecutive segments alternate between the two templates, and the offset of each
segment is the end value of the previous one (continuity), so a trajectory is described by its
start value and one ``(d, s)`` pair per segment.

The piecewise-linear template ``c + s t / d`` is the alternative of Table 5.1.

Library considered: none does template warping; this is numpy, vectorised over segments.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ParameterError
from .segmentation import Segments, segment

TEMPLATES = ("cosine", "linear")


def template_shape(phase: np.ndarray, kind: str = "cosine") -> np.ndarray:
    """Normalised template rising from 0 to 1 for ``phase`` in [0, 1]."""
    if kind == "cosine":
        return 0.5 * (1.0 - np.cos(np.pi * phase))
    if kind == "linear":
        return np.asarray(phase, dtype=np.float64)
    raise ParameterError(f"template kind must be one of {TEMPLATES}; got {kind!r}")


def g1(t, *, d, a, c):
    """Rising half-cosine, eq 5.1."""
    return -a / 2.0 * np.cos(np.pi * np.asarray(t) / d) + (2 * c + a) / 2.0


def g2(t, *, d, a, c):
    """Falling half-cosine, eq 5.2."""
    return a / 2.0 * np.cos(np.pi * np.asarray(t) / d) + (2 * c - a) / 2.0


@dataclass(frozen=True)
class Encoding:
    """Template encoding of one axis.

    Attributes
    ----------
    start : float              value at frame 0 (the first offset c)
    durations : np.ndarray [shape=(K,), int]   frames per segment
    amplitudes : np.ndarray [shape=(K,)]       signed amplitude s of each segment (radians)
    fps : float
    """

    start: float
    durations: np.ndarray
    amplitudes: np.ndarray
    fps: float

    @property
    def n_frames(self) -> int:
        return int(np.sum(self.durations)) + 1

    @property
    def offsets(self) -> np.ndarray:
        """Offset c of each segment (continuity), (K,)."""
        return self.start + np.concatenate([[0.0], np.cumsum(self.amplitudes)[:-1]])


def encode_axis(x: np.ndarray, *, fps: float, min_segment: int | None = None) -> Encoding:
    """Segment one trajectory (T,) and describe it by warping parameters."""
    seg: Segments = segment(x, fps=fps, min_segment=min_segment)
    return Encoding(start=float(seg.values[0]), durations=seg.durations.astype(np.int64),
                    amplitudes=seg.amplitudes.astype(np.float64), fps=float(fps))


def render(start: float, durations, amplitudes, n_frames: int | None = None, *,
           kind: str = "cosine") -> np.ndarray:
    """Warp and concatenate templates: (T,) trajectory.

    Parameters
    ----------
    start : float, the offset of the first segment
    durations : array (K,) of positive segment lengths in frames (may be non-integer)
    amplitudes : array (K,) of signed amplitudes
    n_frames : int, optional; default ``floor(sum(durations)) + 1``.  Past the last segment the
        trajectory holds its final value.
    kind : "cosine" (eq 5.1/5.2) or "linear"
    """
    d = np.asarray(durations, dtype=np.float64)
    s = np.asarray(amplitudes, dtype=np.float64)
    if d.shape != s.shape or d.ndim != 1:
        raise ParameterError(f"durations and amplitudes must be 1-D of equal length; got {d.shape}, {s.shape}")
    if np.any(d <= 0):
        raise ParameterError("segment durations must be positive")
    ends = np.cumsum(d)
    starts = ends - d
    if n_frames is None:
        n_frames = int(np.floor(ends[-1])) + 1 if len(d) else 1
    t = np.arange(n_frames, dtype=np.float64)
    if len(d) == 0:
        return np.full(n_frames, float(start))
    k = np.searchsorted(ends, t, side="left")
    k = np.minimum(k, len(d) - 1)
    offsets = start + np.concatenate([[0.0], np.cumsum(s)[:-1]])
    phase = np.clip((t - starts[k]) / d[k], 0.0, 1.0)
    return offsets[k] + s[k] * template_shape(phase, kind)


def decode_axis(enc: Encoding, *, kind: str = "cosine", n_frames: int | None = None) -> np.ndarray:
    """Trajectory (T,) from an :class:`Encoding`."""
    return render(enc.start, enc.durations, enc.amplitudes, n_frames or enc.n_frames, kind=kind)


def encode(rotvec: np.ndarray, *, fps: float, min_segment: int | None = None) -> list[Encoding]:
    """Encode every column of a ``(T, D)`` trajectory."""
    r = np.asarray(rotvec, dtype=np.float64)
    if r.ndim == 1:
        r = r[:, None]
    return [encode_axis(r[:, j], fps=fps, min_segment=min_segment) for j in range(r.shape[1])]


def decode(encodings: list[Encoding], *, kind: str = "cosine", n_frames: int | None = None) -> np.ndarray:
    """``(T, D)`` trajectory from per-axis encodings."""
    n = n_frames or max(e.n_frames for e in encodings)
    return np.stack([decode_axis(e, kind=kind, n_frames=n) for e in encodings], axis=1)


def encoding_errors(rotvec: np.ndarray, *, fps: float) -> dict[str, float]:
    """Table 5.1 for one trajectory: RMS encoding error with cosine and piecewise-linear templates
    and the RMS amplitude (about the mean) of the original, all in radians, pooled over axes.

    Returns ``{"cosine": …, "linear": …, "rms_amplitude": …, "frames": T*D}`` where the sums of
    squares can be pooled over recordings via ``…_sse`` entries."""
    r = np.asarray(rotvec, dtype=np.float64)
    if r.ndim == 1:
        r = r[:, None]
    encs = encode(r, fps=fps)
    n = len(r)
    out = {}
    for kind in TEMPLATES:
        y = decode(encs, kind=kind, n_frames=n)
        out[f"{kind}_sse"] = float(np.sum((y - r) ** 2))
    out["amp_sse"] = float(np.sum((r - r.mean(axis=0)) ** 2))
    out["frames"] = int(r.size)
    out["segments"] = int(sum(len(e.durations) for e in encs))
    for kind in TEMPLATES:
        out[kind] = float(np.sqrt(out[f"{kind}_sse"] / max(out["frames"], 1)))
    out["rms_amplitude"] = float(np.sqrt(out["amp_sse"] / max(out["frames"], 1)))
    return out


def corpus_encoding_errors(motions, *, by_axis: bool = False) -> dict:
    """Table 5.1 pooled over many :class:`~headmotion.types.Motion` (RMS over all frames).

    With ``by_axis`` also a per-axis breakdown under ``"axes"``."""
    tot = {"cosine_sse": 0.0, "linear_sse": 0.0, "amp_sse": 0.0, "frames": 0, "segments": 0}
    axes = [{k: 0.0 for k in tot} for _ in range(3)]
    for m in motions:
        for j in range(3):
            e = encoding_errors(m.rotvec[:, j], fps=m.fps)
            for k in tot:
                tot[k] += e[k]
                axes[j][k] += e[k]

    def fin(t):
        n = max(t["frames"], 1)
        return {"cosine": float(np.sqrt(t["cosine_sse"] / n)), "linear": float(np.sqrt(t["linear_sse"] / n)),
                "rms_amplitude": float(np.sqrt(t["amp_sse"] / n)), "frames": int(t["frames"]),
                "segments": int(t["segments"])}

    out = fin(tot)
    if by_axis:
        out["axes"] = {name: fin(a) for name, a in zip(("rx", "ry", "rz"), axes)}
    return out


__all__ = ["Encoding", "encode_axis", "decode_axis", "encode", "decode", "render", "template_shape",
           "encoding_errors", "corpus_encoding_errors", "g1", "g2", "TEMPLATES"]
