"""The walk through the library: the decisions of one take, the joins between clips and the take's opening."""

from __future__ import annotations

import numpy as np

from .library import FPS, Weights

#: ``repeat_cost``: how long (seconds) a clip started is remembered
REPEAT_S = 10.0
#: ``wait_s``: the pause and repeat costs of a head that waits (docs/decisions/amount-and-adapt.md)
WAIT_PAUSE_WEIGHT = 3.0
WAIT_REPEAT_COST = 3.0


class _Walk:
    """The decisions of one take (:meth:`MotionMatch.generate`, :class:`MotionMatchStream`): the
    draws from the seed, the clip playing, the spring of the last join and the last two frames.
    ``model`` is a fitted :class:`~.estimator.MotionMatch`: the walk reads its parameters and its
    library (``library_``, :class:`~.library.Library`)."""

    def __init__(self, model, seed: int):
        #: the estimator (its parameters) and the library it walks through
        self.m, self.lib, self.rng = model, model.library_, np.random.default_rng(int(seed))
        self.t, self.pos, self.age = 0, -1, 0
        self.x0, self.v0 = np.zeros(3), np.zeros(3)
        self.last = np.zeros((0, 3))
        self.recent: list[tuple[int, int]] = []  # (frame, library frame) of the clips started lately
        self.quiet = 0  # frames the speech has paused so far
        self.opening = False  # the offset playing out is the take's opening (ease_in)
        self.lam = 4.0 / float(model.blend)
        #: > 0: the rate (per frame) at which a join's pose offset settles (``posture_s``)
        self.settle = 1.0 / (float(model.posture_s) * FPS) if model.posture_s else 0.0

    def hop(self, desc: np.ndarray, goal: np.ndarray | None, speaking: float, n: int) -> np.ndarray:
        """The next ``n`` frames (degrees): one decision for the speech descriptor ``desc``, the
        pose ``goal`` at the goal steps and whether the hop is speech (1) or a pause (0)."""
        m, lib, pos = self.m, self.lib, self.pos
        if m.amount == 0:  # holds the mean pose
            self.t += n
            return np.zeros((n, 3))
        # the head waits in a pause that has already lasted wait_s before this hop
        waiting = m.wait_s > 0 and not speaking and self.quiet >= float(m.wait_s) * FPS
        self.quiet = 0 if speaking else self.quiet + n  # frames of pause so far
        pw = WAIT_PAUSE_WEIGHT if waiting else None
        repeat = max(float(m.repeat_cost), WAIT_REPEAT_COST) if waiting else float(m.repeat_cost)
        w = Weights.of(m)
        if self.t == 0:  # with ease_in, as if the head were at the mean pose, at rest
            rest = np.zeros(3) if m.ease_in > 0 else None
            cost = lib.costs(w, desc, rest, rest, goal, speaking, pause_weight=pw)
        else:
            vel = self.last[-1] - self.last[-2] if len(self.last) >= 2 else np.zeros(3)
            ahead = self.last[-1] + vel
            switch = float(m.switch_cost) * (1.0 if speaking else float(m.pause_switch))
            cost = lib.costs(w, desc, ahead, vel, goal, speaking, pause_weight=pw) + switch
            if 0 <= pos < len(cost) and pos + n <= lib.ends[pos - 1]:  # the clip playing goes on
                cost[pos] = lib.costs(w, desc, ahead, vel, goal, speaking, only=pos, pause_weight=pw)
            base_pos = cost[pos] if 0 <= pos < len(cost) else np.inf
        if repeat > 0 and self.recent:  # clips started in the last REPEAT_S seconds cost more
            H = int(m.hop)
            for _t0, j0 in self.recent:  # ``cost`` is this decision's own array
                lo, hi = max(0, j0 - H), j0 + H
                cost[lo:hi] += repeat
            if 0 <= pos < len(cost) and pos + n <= lib.ends[pos - 1]:
                cost[pos] = base_pos
        j = lib.draw(cost, self.rng, top_k=m.top_k, temperature=m.temperature, hop=m.hop,
                     distinct=self.t == 0)  # a take's first movement: from different clips
        if (m.repeat_cost > 0 or m.wait_s > 0) and j != pos:
            self.recent = [(t0, j0) for t0, j0 in self.recent if self.t - t0 < REPEAT_S * FPS] + [(self.t, j)]
        if self.t > 0 and j != pos:  # a join: carry on from where the motion was going
            self.x0 = ahead - lib.poses[j]
            self.v0 = vel - lib.velocities[j]
            self.age, self.opening = 0, False
        elif self.t == 0 and m.ease_in > 0:  # the take opens from the mean pose, at rest
            self.x0, self.v0, self.age = -lib.poses[j], -lib.velocities[j], 0
            self.opening = True
        a = np.arange(self.age, self.age + n, dtype=np.float64)[:, None]
        if self.opening:  # the opening settles within ease_in, as one critically damped spring
            lam = max(self.lam, 4.0 / (float(m.ease_in) * FPS))
            off = (self.x0 + (self.v0 + lam * self.x0) * a) * np.exp(-lam * a)
        elif self.settle:  # the pose offset settles slowly, the velocity offset over the blend
            off = self.x0 * np.exp(-self.settle * a) + self.v0 * a * np.exp(-self.lam * a)
        else:  # both settle as one critically damped spring
            off = (self.x0 + (self.v0 + self.lam * self.x0) * a) * np.exp(-self.lam * a)
        frames = lib.poses[j:j + n] + off
        self.age += n
        self.pos = j + n
        self.t += n
        self.last = np.concatenate([self.last, frames])[-2:]
        return frames
