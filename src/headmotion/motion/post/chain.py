"""The post-processing chain: the stages every synthesis system passes its raw output through,
configured by one small dataclass of fitted tables (:class:`PostTables`) and run, with state, by
one class (:class:`PostChain`) offline and on a stream alike.

Stages (each off when its table is None):

``restore``     band / variance restoration and posture drift about the running mean
                (:class:`~headmotion.motion.post.restore.CausalPost`)
``denormalise`` ``x · sd + mean``: a network's normalised output to rotation vectors
``to_rotvec``   pitch, yaw, roll angles to rotation vectors
``settle``      slowing down in pauses (:class:`~headmotion.motion.pauses.CausalPauseWeight` over
                the speech flags, :class:`~headmotion.motion.pauses.PauseSettler`)
``amplify``     per-axis amplitude gains about a centre pose
``shape``       speed shaping (:func:`~headmotion.motion.post.speed_shaping.product_shaper`)
``limit``       the soft range limit (:func:`~headmotion.motion.post.range_limit.soft_range`)

The order is part of the tables, because the systems' raw outputs live in different spaces and
their stages were fitted in different orders (``docs/decisions/post-chain.md``):
:data:`DNN_ORDER`, :data:`TEMPLATE_ORDER`, :data:`LE2012_ORDER`.

Every stage is causal and keeps its state, so pushing an utterance in chunks gives what one push
gives, and :meth:`PostChain.push_one` (one frame as a list of floats, for streams that emit a frame
per 10 ms chunk) gives what :meth:`PostChain.push` of that frame gives.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from ...rotations import pitch_yaw_roll_to_rotvec, pitch_yaw_roll_to_rotvec_one
from ..control import apply_gain_angles
from ..pauses import CausalPauseWeight, PauseSettler
from .range_limit import soft_range
from .restore import CausalPost
from .speed_shaping import product_shaper

#: a network's output: restored in its normalised space, then motion, shaped, limited, settled
DNN_ORDER = ("restore", "denormalise", "shape", "limit", "settle")
#: the generator's angles: settled, amplitude-matched, shaped, then the slow band restored
TEMPLATE_ORDER = ("settle", "amplify", "shape", "restore")
#: the ascent's angles: settled, to rotation vectors, band-restored, shaped
LE2012_ORDER = ("settle", "to_rotvec", "restore", "shape")

STAGES = ("restore", "denormalise", "to_rotvec", "settle", "amplify", "shape", "limit")


@dataclass(frozen=True)
class PostTables:
    """What configures a :class:`PostChain`: the stage order and the fitted tables (arrays over the
    D axes; a stage whose table is None, or whose switch is off, passes its input through).

    Parameters
    ----------
    fps : frame rate of the motion (Hz)
    order : the stages in order (names of :data:`STAGES`)
    band_gains : ``(B, D)`` per-band gains of ``restore`` (replaces ``gv``)
    gv : ``(D,)`` global variance ratio of ``restore``
    drift_share, drift_sd, drift_tau_s : posture drift of ``restore`` (share of the variance,
        ``(D,)`` SD it scales, time constant in s); off with share 0
    norm_mean, norm_sd : ``(D,)`` of ``denormalise``
    idle : speed in pauses of ``settle`` as a fraction of the motion's own (None or >= 1: off)
    pause_pull : pull (1/s) towards ``pause_pose`` inside pauses
    pause_pose : ``(D,)`` pose the settling pulls towards (and its mean pose)
    amplitude_gains, amplitude_centre : ``(D,)`` of ``amplify``
    speed_map : ``(2, Q)`` table of ``shape``
    range_bounds, range_centre : ``(2, D)`` knee and asymptote, ``(D,)`` centre of ``limit``
    """

    fps: float
    order: tuple[str, ...]
    band_gains: np.ndarray | None = None
    gv: np.ndarray | None = None
    drift_share: float = 0.0
    drift_sd: np.ndarray | None = None
    drift_tau_s: float = 4.0
    norm_mean: np.ndarray | None = None
    norm_sd: np.ndarray | None = None
    idle: float | None = None
    pause_pull: float = 0.0
    pause_pose: np.ndarray | None = None
    amplitude_gains: np.ndarray | None = None
    amplitude_centre: np.ndarray | None = None
    speed_map: np.ndarray | None = None
    range_bounds: np.ndarray | None = None
    range_centre: np.ndarray | None = None

    def __post_init__(self):
        unknown = [s for s in self.order if s not in STAGES]
        if unknown:
            raise ValueError(f"unknown post stages {unknown}; the stages are {list(STAGES)}")

    def only(self, *stages: str) -> "PostTables":
        """The same tables with only ``stages`` kept (in this order)."""
        return replace(self, order=tuple(s for s in self.order if s in stages))

    @property
    def settles(self) -> bool:
        """Whether the chain slows down in pauses (and so needs speech flags)."""
        return "settle" in self.order and self.idle is not None and float(self.idle) < 1.0

    @property
    def restores(self) -> bool:
        """Whether the ``restore`` stage changes anything (gains or drift)."""
        return "restore" in self.order and (self.band_gains is not None or self.gv is not None
                                            or float(self.drift_share) > 0)


class _Map:
    """A stage that passes each block of frames through ``fn`` (a function, or a stateful object's
    ``push``) and needs no speech flags."""

    def __init__(self, fn):
        self.fn = fn

    def push(self, x, flags):  # noqa: ARG002
        return self.fn(x)


def _denormalise(x, mean, sd):
    return np.asarray(np.asarray(x, dtype=np.float64) * sd + mean, dtype=np.float64)


class _ToRotvec:
    def push(self, x, flags):  # noqa: ARG002
        return pitch_yaw_roll_to_rotvec(x[:, 0], x[:, 1], x[:, 2])

    @staticmethod
    def push_one(x, flag):  # noqa: ARG004
        return list(pitch_yaw_roll_to_rotvec_one(*x))


class _Settle:
    def __init__(self, t: PostTables):
        self.weight = CausalPauseWeight(fps=float(t.fps))
        pose = None if t.pause_pose is None else np.asarray(t.pause_pose, dtype=np.float64)
        self.settler = PauseSettler(fps=float(t.fps), idle=float(t.idle), pull=float(t.pause_pull), mean_pose=pose)

    def push(self, x, flags):
        if flags is None:   # no speech flags (no audio): nothing to settle
            return x
        return self.settler.push(x, self.weight.push(flags))

    def push_one(self, x, flag):
        return self.settler.push_one(x, self.weight.push_one(flag))


def _stage(name: str, t: PostTables, rng):
    """The stage ``name`` with fresh state, or None when its table says it is off."""
    if name == "restore":
        if not t.restores:
            return None
        return _Map(CausalPost(gv=t.gv, band_gains=t.band_gains, share=float(t.drift_share), sd=t.drift_sd,
                               fps=float(t.fps), tau_s=float(t.drift_tau_s), rng=rng).push)
    if name == "denormalise":
        return None if t.norm_mean is None else _Map(partial(_denormalise, mean=t.norm_mean, sd=t.norm_sd))
    if name == "to_rotvec":
        return _ToRotvec()
    if name == "settle":
        return _Settle(t) if t.settles else None
    if name == "amplify":
        if t.amplitude_gains is None:
            return None
        gains = np.asarray(t.amplitude_gains, dtype=np.float64)
        return _Map(partial(apply_gain_angles, mean_pose=t.amplitude_centre, gain=gains))
    if name == "shape":
        return _Map(product_shaper(t.speed_map, float(t.fps)).push) if t.speed_map is not None else None
    if t.range_bounds is None:
        return None
    return _Map(partial(soft_range, centre=t.range_centre, bounds=t.range_bounds))


class PostChain:
    """The stages of ``tables`` in order, with fresh state (module docstring).

    Parameters
    ----------
    tables : PostTables
    seed : int or None, seeds the posture drift (``numpy.random.default_rng(seed)``; used only
        with ``drift_share > 0``)
    """

    def __init__(self, tables: PostTables, *, seed: int | None = None):
        rng = None
        if "restore" in tables.order and float(tables.drift_share) > 0:
            rng = np.random.default_rng(None if seed is None else int(seed))
        self.tables = tables
        self.stages = [s for s in (_stage(n, tables, rng) for n in tables.order) if s is not None]

    @property
    def identity(self) -> bool:
        """True when every stage is off (the chain returns its input)."""
        return not self.stages

    def push(self, x: np.ndarray, speaking: np.ndarray | None = None) -> np.ndarray:
        """The next frames ``x`` ``(n, D)`` through every stage; ``speaking`` ``(n,)`` the frames'
        speech flags (the settling is skipped without them)."""
        x = np.asarray(x, dtype=np.float64)
        if len(x) == 0:
            return x.copy()
        for stage in self.stages:
            x = stage.push(x, speaking)
        return x

    def push_one(self, x, speaking: bool = True) -> list[float]:
        """One frame ``x`` (D floats) with its speech flag: :meth:`push` of that frame, on scalars
        where a stage has a one-frame path (the settling, the rotation)."""
        x = [float(v) for v in x]
        for stage in self.stages:
            one = getattr(stage, "push_one", None)
            if one is not None:
                x = one(x, speaking)
            else:
                x = stage.push(np.asarray(x, dtype=np.float64)[None], None if speaking is None
                               else np.array([speaking]))[0].tolist()
        return x


__all__ = ["PostTables", "PostChain", "DNN_ORDER", "TEMPLATE_ORDER", "LE2012_ORDER", "STAGES"]
