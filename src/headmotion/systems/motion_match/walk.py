"""The walk through the library: the decisions of one take, the joins between clips and the take's opening."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..decisions import answer_alone
from .library import FPS, Library, Query, Weights

#: ``repeat_cost``: how long (seconds) a clip started is remembered
REPEAT_S = 10.0
#: ``wait_s``: the pause and repeat costs of a head that waits (docs/decisions/amount-and-adapt.md)
WAIT_PAUSE_WEIGHT = 3.0
WAIT_REPEAT_COST = 3.0


@dataclass(frozen=True)
class Ask:
    """A decision's question to its library: the library, the :class:`~.library.Query` (None: no
    search, the head holds the mean pose), the frames of the hop, and what the walk adds to the
    costs: ``repeat`` on clips started lately, ``switch`` on leaving the clip playing."""

    library: Library
    query: Query | None
    n: int
    repeat: float = 0.0
    switch: float = 0.0

    @property
    def batch(self):
        """The asks answered together with this one (:mod:`..decisions`): those of its library;
        None without a query."""
        return None if self.query is None else (Ask, id(self.library))

    @staticmethod
    def answer_many(asks: "list[Ask]") -> list:
        """The library's costs for each ask's query, by one ``costs_many``: each row the one its
        ask gets alone."""
        return list(asks[0].library.costs_many([a.query for a in asks]))


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
        pose ``goal`` at the goal steps and whether the hop is speech (1) or a pause (0) — its
        :meth:`ask` answered alone."""
        ask = self.ask(desc, goal, speaking, n)
        return self.answer(ask, answer_alone(ask))

    def ask(self, desc: np.ndarray, goal: np.ndarray | None, speaking: float, n: int) -> Ask:
        """The first half of :meth:`hop`: the decision's question to the library (its
        :attr:`Ask.query`; None when the head holds the mean pose), the walk's state moved on to
        the decision.  :meth:`answer` with the library's costs for it finishes the hop."""
        m = self.m
        if m.amount == 0:  # holds the mean pose
            return Ask(self.lib, None, n)
        # the head waits in a pause that has already lasted wait_s before this hop
        waiting = m.wait_s > 0 and not speaking and self.quiet >= float(m.wait_s) * FPS
        self.quiet = 0 if speaking else self.quiet + n  # frames of pause so far
        pw = WAIT_PAUSE_WEIGHT if waiting else None
        repeat = max(float(m.repeat_cost), WAIT_REPEAT_COST) if waiting else float(m.repeat_cost)
        w = Weights.of(m)
        if self.t == 0:  # with ease_in, as if the head were at the mean pose, at rest
            rest = np.zeros(3) if m.ease_in > 0 else None
            return Ask(self.lib, Query(w, desc, rest, rest, goal, speaking, pw), n, repeat=repeat)
        vel = self.last[-1] - self.last[-2] if len(self.last) >= 2 else np.zeros(3)
        ahead = self.last[-1] + vel
        switch = float(m.switch_cost) * (1.0 if speaking else float(m.pause_switch))
        return Ask(self.lib, Query(w, desc, ahead, vel, goal, speaking, pw), n, repeat=repeat, switch=switch)

    def answer(self, ask: Ask, row: np.ndarray | None) -> np.ndarray:
        """The second half of :meth:`hop`: the next ``ask.n`` frames (degrees) from the library's
        costs ``row`` for ``ask.query`` (:meth:`Library.costs_many <.library.Library.costs_many>`):
        the draw from the seed, the join, the frames."""
        m, lib, pos, n = self.m, self.lib, self.pos, ask.n
        if ask.query is None:  # holds the mean pose
            self.t += n
            return np.zeros((n, 3))
        cost = np.where(lib.can_start, row, np.inf)
        goes_on = self.t > 0 and 0 <= pos < len(cost) and pos + n <= lib.ends[pos - 1]  # the clip playing
        if self.t > 0:
            ahead, vel = ask.query.pose, ask.query.vel
            cost = cost + ask.switch
            if goes_on:
                cost[pos] = row[pos]
        repeat = ask.repeat
        if repeat > 0 and self.recent:  # clips started in the last REPEAT_S seconds cost more
            H = int(m.hop)
            for _t0, j0 in self.recent:  # ``cost`` is this decision's own array
                lo, hi = max(0, j0 - H), j0 + H
                cost[lo:hi] += repeat
            if goes_on:
                cost[pos] = row[pos]
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
