"""Core data types: arrays that carry their own rate (docs/design.md "Core types"; thesis §2.2.3).

All are frozen dataclasses, time first:

* :class:`Audio` — mono float32 samples ``(n,)`` and a sample rate in Hz.
* :class:`Motion` — head rotation relative to the torso as rotation vectors ``(T, 3)`` in radians
  (axis convention in :mod:`headmotion.rotations`), an optional translation ``(T, 3)`` in metres,
  and a frame rate in frames/s.
* :class:`FeatureTrack` — speech features ``(T, D)`` float32 at a frame rate, with one name per
  column.

Constructors validate shapes and finiteness and make the arrays read-only, so a value once built
stays valid.  Missing motion frames are represented by NaN rows only before a reader fills them;
a finished :class:`Motion` is finite (use ``Motion(..., allow_nan=True)`` inside readers).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import rotations
from .errors import ParameterError


def _readonly(a: np.ndarray, source) -> np.ndarray:
    """A read-only contiguous array.  ``a`` is copied only when it is still the caller's buffer
    (``source``), so building a value never freezes the caller's array and an array the
    constructor already converted (a fresh ``astype``) is not copied twice."""
    c = np.ascontiguousarray(a)
    if c.flags.writeable and np.may_share_memory(c, np.asarray(source)):
        c = c.copy()
    c.setflags(write=False)
    return c


def check_rate(name: str, value: float) -> float:
    """``value`` as a positive finite float, else a :class:`ParameterError` naming ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a positive number; got {value!r}") from None
    if not np.isfinite(v) or v <= 0:
        raise ParameterError(f"{name} must be a positive finite number; got {value!r}")
    return v


def _pcm_to_float(s: np.ndarray) -> np.ndarray:
    """float32 samples; integer PCM scaled to [-1, 1)."""
    if np.issubdtype(s.dtype, np.signedinteger):
        return (s.astype(np.float64) / float(2 ** (8 * s.dtype.itemsize - 1))).astype(np.float32)
    if np.issubdtype(s.dtype, np.unsignedinteger):
        half = float(2 ** (8 * s.dtype.itemsize - 1))
        return ((s.astype(np.float64) - half) / half).astype(np.float32)
    return s.astype(np.float32, copy=False)


@dataclass(frozen=True, eq=False)
class Audio:
    """Mono audio.

    Attributes
    ----------
    samples : np.ndarray [shape=(n,), dtype=float32], finite, nominally in [-1, 1]; integer PCM
        is scaled to that range (signed ``intN`` divided by ``2**(N-1)``, unsigned ``uint8``
        centred on 128 first), as soundfile reads it
    sample_rate : int, Hz
    """

    samples: np.ndarray
    sample_rate: int

    def __post_init__(self):
        s = np.asarray(self.samples)
        if s.ndim != 1:
            raise ParameterError(f"Audio samples must be one-dimensional (mono); given shape {s.shape}")
        s = _pcm_to_float(s)
        if not np.all(np.isfinite(s)):
            raise ParameterError("Audio buffer is not finite everywhere (NaN or inf samples)")
        rate = check_rate("sample_rate", self.sample_rate)
        if rate != int(rate):
            raise ParameterError(f"sample_rate must be a whole number of Hz; got {self.sample_rate!r}")
        object.__setattr__(self, "samples", _readonly(s, self.samples))
        object.__setattr__(self, "sample_rate", int(rate))

    @property
    def duration(self) -> float:
        """Length in seconds."""
        return len(self.samples) / self.sample_rate

    def __len__(self) -> int:
        return len(self.samples)

    def slice_seconds(self, start: float, stop: float | None = None) -> "Audio":
        a = int(round(start * self.sample_rate))
        b = None if stop is None else int(round(stop * self.sample_rate))
        return Audio(self.samples[a:b], self.sample_rate)

    def __repr__(self) -> str:
        return f"Audio({self.duration:.3f} s at {self.sample_rate} Hz)"


class _Frames:
    """Frame count, duration and frame times of a value whose ``len`` is its number of frames at
    ``fps`` (:class:`Motion`, :class:`FeatureTrack`)."""

    fps: float

    @property
    def n_frames(self) -> int:
        return len(self)

    @property
    def duration(self) -> float:
        """Length in seconds."""
        return len(self) / self.fps

    @property
    def times(self) -> np.ndarray:
        """Frame times in seconds, ``(T,)``."""
        return np.arange(len(self)) / self.fps


@dataclass(frozen=True, eq=False)
class Motion(_Frames):
    """Head rotation over time.

    Attributes
    ----------
    rotvec : np.ndarray [shape=(T, 3), dtype=float64]
        Rotation vectors (rx, ry, rz) in radians, head relative to torso; for small angles the
        columns are pitch, yaw, roll (see :mod:`headmotion.rotations`).
    fps : float, frames per second
    translation : np.ndarray [shape=(T, 3)] or None
        Head position relative to the torso (or the clip's mean position), metres.
    meta : dict
        Free-form provenance (source file, joint name, gaps filled, …); JSON-serialisable.
    """

    rotvec: np.ndarray
    fps: float
    translation: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    allow_nan: bool = field(default=False, repr=False)

    def __post_init__(self):
        r = np.asarray(self.rotvec, dtype=np.float64)
        if r.ndim != 2 or r.shape[1] != 3:
            raise ParameterError(f"Motion.rotvec must have shape (T, 3); given shape {r.shape}")
        if not self.allow_nan and not np.all(np.isfinite(r)):
            bad = int(np.sum(~np.all(np.isfinite(r), axis=1)))
            raise ParameterError(f"Motion.rotvec contains NaN or inf in {bad} of {len(r)} frames")
        object.__setattr__(self, "rotvec", _readonly(r, self.rotvec))
        object.__setattr__(self, "fps", check_rate("fps", self.fps))
        if self.translation is not None:
            t = np.asarray(self.translation, dtype=np.float64)
            if t.shape != r.shape:
                raise ParameterError(
                    f"Motion.translation must have the shape of rotvec {r.shape}; given {t.shape}"
                )
            if not self.allow_nan and not np.all(np.isfinite(t)):
                raise ParameterError("Motion.translation contains NaN or inf")
            object.__setattr__(self, "translation", _readonly(t, self.translation))
        object.__setattr__(self, "meta", dict(self.meta))

    def __len__(self) -> int:
        return len(self.rotvec)

    # -- conversions ------------------------------------------------------------------------
    def as_matrix(self) -> np.ndarray:
        """``(T, 3, 3)`` rotation matrices, head → torso."""
        return rotations.rotvec_to_matrix(self.rotvec)

    def as_quat(self, *, scalar_first: bool = True) -> np.ndarray:
        """``(T, 4)`` unit quaternions, ``(w, x, y, z)`` by default."""
        return rotations.rotvec_to_quat(self.rotvec, scalar_first=scalar_first)

    def as_euler(self, order: str, *, degrees: bool = False) -> np.ndarray:
        """``(T, 3)`` Euler angles about the axes of ``order`` (e.g. ``"YXZ"``, intrinsic)."""
        return rotations.rotvec_to_euler(self.rotvec, order, degrees=degrees)

    def as_pitch_yaw_roll(self, *, degrees: bool = False) -> np.ndarray:
        """``(T, 3)`` columns pitch, yaw, roll (intrinsic yaw → pitch → roll)."""
        return rotations.rotvec_to_pitch_yaw_roll(self.rotvec, degrees=degrees)

    @classmethod
    def from_matrix(cls, matrix, fps: float, **kw) -> "Motion":
        return cls(rotations.matrix_to_rotvec(matrix), fps, **kw)

    @classmethod
    def from_quat(cls, quat, fps: float, *, scalar_first: bool = True, **kw) -> "Motion":
        return cls(rotations.quat_to_rotvec(quat, scalar_first=scalar_first), fps, **kw)

    @classmethod
    def from_euler(cls, angles, order: str, fps: float, *, degrees: bool = False, **kw) -> "Motion":
        return cls(rotations.euler_to_rotvec(angles, order, degrees=degrees), fps, **kw)

    # -- simple transforms --------------------------------------------------------------------
    def replace(self, **changes) -> "Motion":
        kw = dict(rotvec=self.rotvec, fps=self.fps, translation=self.translation, meta=self.meta,
                  allow_nan=self.allow_nan)
        kw.update(changes)
        return Motion(**kw)

    def slice_frames(self, start: int, stop: int | None = None) -> "Motion":
        tr = None if self.translation is None else self.translation[start:stop]
        return self.replace(rotvec=self.rotvec[start:stop], translation=tr)

    def scaled(self, gain: float) -> "Motion":
        """Amplitude scaled by ``gain`` about the zero (rest) pose."""
        return self.replace(rotvec=self.rotvec * float(gain))

    def resample(self, fps: float) -> "Motion":
        """Resample to ``fps`` by interpolating rotations (spherical, via scipy's Slerp).

        Frame ``t`` is at time ``t / fps`` (the convention of every resampler, see
        :mod:`headmotion.align`); the frame count is ``round(duration * fps)``; times past the
        last frame hold it.  A constant frame rate is assumed."""
        from scipy.spatial.transform import Rotation, Slerp

        fps = check_rate("fps", fps)
        if abs(fps - self.fps) < 1e-9:
            return self
        n_new = max(1, int(round(self.duration * fps)))
        t_new = np.arange(n_new) / fps
        t_old = self.times
        t_new = np.clip(t_new, t_old[0], t_old[-1])
        if len(self) == 1:
            rv = np.repeat(self.rotvec, n_new, axis=0)
            tr = None if self.translation is None else np.repeat(self.translation, n_new, axis=0)
        else:
            rv = Slerp(t_old, Rotation.from_rotvec(np.array(self.rotvec)))(t_new).as_rotvec()
            tr = None
            if self.translation is not None:
                tr = np.stack([np.interp(t_new, t_old, self.translation[:, k]) for k in range(3)], 1)
        return self.replace(rotvec=rv, fps=fps, translation=tr)

    def __repr__(self) -> str:
        deg = np.degrees(self.rotvec.std(axis=0)) if len(self) else np.zeros(3)
        return (
            f"Motion({len(self)} frames at {self.fps:g} fps = {self.duration:.2f} s, "
            f"SD pitch/yaw/roll = {deg[0]:.2f}/{deg[1]:.2f}/{deg[2]:.2f} deg)"
        )


@dataclass(frozen=True, eq=False)
class FeatureTrack(_Frames):
    """Frame-wise features.

    Attributes
    ----------
    values : np.ndarray [shape=(T, D), dtype=float32]
    fps : float, frames per second
    names : tuple[str, ...] of length D
    """

    values: np.ndarray
    fps: float
    names: tuple[str, ...]

    def __post_init__(self):
        v = np.asarray(self.values)
        if v.ndim == 1:
            v = v[:, None]
        if v.ndim != 2:
            raise ParameterError(f"FeatureTrack.values must have shape (T, D); given shape {v.shape}")
        v = v.astype(np.float32, copy=False)
        if not np.all(np.isfinite(v)):
            raise ParameterError("FeatureTrack.values contains NaN or inf")
        names = tuple(str(n) for n in self.names)
        if len(names) != v.shape[1]:
            raise ParameterError(
                f"FeatureTrack has {v.shape[1]} columns but {len(names)} names: {names!r}"
            )
        object.__setattr__(self, "values", _readonly(v, self.values))
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "fps", check_rate("fps", self.fps))

    def __len__(self) -> int:
        return len(self.values)

    @property
    def dim(self) -> int:
        return self.values.shape[1]

    def slice_frames(self, start: int, stop: int | None = None) -> "FeatureTrack":
        return FeatureTrack(self.values[start:stop], self.fps, self.names)

    def select(self, names) -> "FeatureTrack":
        idx = [self.names.index(n) for n in names]
        return FeatureTrack(self.values[:, idx], self.fps, tuple(names))

    def __repr__(self) -> str:
        return f"FeatureTrack({self.n_frames}×{self.dim} at {self.fps:g} fps, names={self.names[:4]}{'…' if self.dim > 4 else ''})"


__all__ = ["Audio", "Motion", "FeatureTrack"]
