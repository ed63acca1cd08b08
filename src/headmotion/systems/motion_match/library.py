"""The library of recorded movements: speech descriptors, clips, and the search tables with the costs and the draw."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: frames per second of the library and the output
FPS = 25.0
#: the prosody matched (``prosody="f0e"``), by feature set and name: the MFCC front end's energy and
#: its delta, Praat's log F0, energy, Δlog F0 and voicing
PROSODY = (("mfcc", {}, ("energy", "d_energy")), ("f0e", {"voicing": True}, ("logf0", "energy", "d_logf0", "voiced")))
#: a frame-to-frame change above this (degrees at 25 fps, 250 °/s) is a tracking glitch: clips end there
MAX_STEP_DEG = 10.0
#: the voicing column within PROSODY's columns
VOICING = 5
#: a hop is speech when at least this share of its frames is voiced (else a pause)
SPEAKING_SHARE = 0.2
#: the f0e-live prosody matched (the shipped models; ``live``), by name, and its settings: no
#: smoothing or delta lookahead, so a frame is final 39 ms after its start at 16 kHz
LIVE_NAMES = ("energy", "d_energy", "logf0", "d_logf0", "voiced")
LIVE_FEATURES = {"smooth_lookahead": 0, "delta_lookahead": 0, "voicing": True}
#: ``centred``: the smoothing (2 frames at 25 fps) and the 5-frame deltas centred on their frame
CENTRED_FEATURES = {"smooth_lookahead": 1, "delta_lookahead": 2}
#: ``reader="praat"``: how Praat reads the f0e-live prosody's pitch (:mod:`headmotion.features.praat_stream`)
#: — offline in blocks of 30 s with 1 s read on each side, one 40 ms analysis step a frame, unvoiced
#: frames interpolated; ``live`` one frame at a time on the last 0.3 s of audio at a 20 ms step,
#: unvoiced frames held (docs/decisions/read-any-voice.md)
PRAAT_OFFLINE = {"reader": "praat", "praat_block": 750, "praat_back_s": 1.0, "praat_ahead_s": 1.0,
                 "praat_step": 0.04, "interpolate": True}
PRAAT_LIVE = {"reader": "praat", "praat_block": 1, "praat_back_s": 0.3, "praat_ahead_s": 0.0, "praat_step": 0.02,
              "interpolate": False}
#: frames of the moving average over the features before they are matched
SMOOTH = 5
#: ``amount``: how far the choice leans per doubling — a frame's cost changes by
#: ``AMOUNT_LEAN · log2(amount)`` times how much more (in SDs of log speed) its next hop moves than
#: the library's average hop (docs/decisions/amount.md)
AMOUNT_LEAN = 0.5


def _smooth(x: np.ndarray, width: int, *, causal: bool = False) -> np.ndarray:
    """Moving average over ``width`` frames along axis 0, centred or (``causal``) ending at each
    frame; edges repeated."""
    if width <= 1 or len(x) == 0:
        return x
    before = width - 1 if causal else width // 2
    pad = np.concatenate([np.repeat(x[:1], before, 0), x, np.repeat(x[-1:], width - 1 - before, 0)])
    c = np.cumsum(np.concatenate([np.zeros((1, x.shape[1])), pad]), axis=0)
    return (c[width:] - c[:-width]) / width


def speech_descriptors(feats: np.ndarray, taps: np.ndarray, *, causal: bool = False) -> np.ndarray:
    """``(T, len(taps) * D)``: the (smoothed) features of each frame at the offsets ``taps``
    (frames; edges repeated) — the speech around a frame, as matched.  ``causal``: the smoothing
    reads no frame after the one it is for (with taps ≤ 0, nothing after the frame is read)."""
    T = len(feats)
    s = _smooth(feats.astype(np.float64), SMOOTH, causal=causal)
    idx = np.clip(np.arange(T)[:, None] + taps[None, :], 0, max(T - 1, 0))
    return s[idx].reshape(T, -1).astype(np.float32)


def clip_starts(motion: np.ndarray) -> np.ndarray:
    """``(T,)`` bool: the frames of one recording's motion (degrees, 25 fps) where a clip starts —
    the first frame, and each frame after a jump above :data:`MAX_STEP_DEG` (a tracking glitch)."""
    starts = np.zeros(len(motion), bool)
    starts[:1] = True
    starts[1:] = np.abs(np.diff(motion, axis=0)).max(axis=1) > MAX_STEP_DEG
    return starts


def clean_clips(motion: np.ndarray, starts: np.ndarray, hz: float, *, fps: float = FPS) -> np.ndarray:
    """One recording's motion with each clip (``starts``: :func:`clip_starts`) low-passed at ``hz``
    by a zero-phase 4th-order Butterworth filter (``scipy.signal.sosfiltfilt``), so a face
    tracker's frame-to-frame jitter is not replayed; clips too short for the filter's padding are
    padded less, clips under 4 frames kept as they are."""
    from scipy.signal import butter, sosfiltfilt

    sos = butter(4, hz, fs=fps, output="sos")
    out = np.array(motion, dtype=np.float64)
    bounds = np.append(np.flatnonzero(starts), len(motion))
    for a, b in zip(bounds[:-1], bounds[1:]):
        if b - a >= 4:
            out[a:b] = sosfiltfilt(sos, out[a:b], axis=0, padlen=min(b - a - 1, 15))
    return out.astype(np.asarray(motion).dtype)


def read_ahead(feats: np.ndarray, shift: int) -> np.ndarray:
    """``feats`` with ``shift`` copies of its last row after it: the rows a ``lookahead_ms`` decision
    reads past a file's end (the speech is taken to go on as it ended; nothing when ``feats`` is empty)."""
    if shift <= 0 or len(feats) == 0:
        return feats
    return np.concatenate([feats, np.repeat(feats[-1:], int(shift), 0)])


def descriptor_of_last(past: np.ndarray, taps: np.ndarray) -> np.ndarray:
    """The causal descriptor (:func:`speech_descriptors` with ``causal=True``) of the last row of
    ``past`` — the rows up to that frame, at least as many as the taps and the smoothing reach
    back, or every row since the start (which is then repeated before it, as there)."""
    need = int(-taps.min()) + SMOOTH
    p = np.asarray(past[-need:])
    if len(p) < need:
        p = np.concatenate([np.repeat(p[:1], need - len(p), 0), p])
    return speech_descriptors(p, taps, causal=True)[-1]



#: :func:`cheapest` looks for its threshold among every STRIDE-th cost
STRIDE = 16


def cheapest(cost: np.ndarray, k: int) -> np.ndarray:
    """The ``k`` cheapest entries of ``cost``, cheapest first (ties in library order).

    The k-th smallest of every :data:`STRIDE`-th cost bounds the k-th smallest of all, so only the
    entries under that bound (about ``STRIDE * k``) are sorted: the same entries as a partition of
    the whole array, an order of magnitude faster on a library of 21 000 frames (a live stream
    makes this choice every 80 ms)."""
    sub = cost[::STRIDE]
    cand = np.flatnonzero(cost <= np.partition(sub, k - 1)[k - 1]) if len(sub) >= k else np.arange(len(cost))
    return cand[np.lexsort((cand, cost[cand]))[:k]]


@dataclass(frozen=True)
class Weights:
    """The cost settings a decision is scored with (the estimator's parameters of the same names)."""

    speech_weight: float
    target_weight: float
    pause_weight: float
    pause_speed: bool
    pose_weight: float
    velocity_weight: float
    amount: float
    base_cost: float

    @classmethod
    def of(cls, params) -> "Weights":
        """The settings of ``params`` (an object with these attributes, e.g. the estimator)."""
        return cls(**{k: getattr(params, k) for k in cls.__dataclass_fields__})


@dataclass(frozen=True)
class Query:
    """One decision's question to the library (:meth:`Library.costs_many`): the settings ``w``, the
    speech descriptor ``s``, the pose and velocity the motion is heading for (degrees; None: no
    pose cost), the pose ``goal`` at the goal steps (None: no goal), whether the hop is speech (1)
    or a pause (0), and a ``pause_weight`` replacing ``w``'s (None: ``w``'s)."""

    w: Weights
    s: np.ndarray
    pose: np.ndarray | None
    vel: np.ndarray | None
    goal: np.ndarray | None = None
    speaking: float = 1.0
    pause_weight: float | None = None


#: queries per matrix product in :func:`products`: blocks of this many, the last padded with zeros
#: to the fewest of :data:`QUERY_WIDTHS` that hold it, so that a query is computed by the same
#: kernel, in the same place of its tile, alone and among any others
QUERY_BLOCK = 8
#: the widths a block of queries may have: a lone decision is a block of 2 (the query and a row of
#: zeros), a quarter of the arithmetic of a block of 8, with the same bits (a block of 1 is a
#: matrix–vector product, which rounds differently)
QUERY_WIDTHS = (2, 4, 8)
#: library frames per matrix product of a block of :data:`QUERY_BLOCK` queries (a narrower block
#: takes proportionally more): few enough that OpenBLAS computes each product on one thread (it
#: splits one of more than 2¹⁸ multiply-adds between threads, which rounds differently), so the
#: costs are the same bits whatever the process's BLAS threads
ROW_BLOCK = 768


def products(table: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """``(n, N)`` float64: ``queries (n, D) · table (N, D)ᵀ`` as BLAS matrix products (float32 gemm)
    of blocks of :data:`QUERY_BLOCK` queries (the last of 2, 4 or 8) by at most
    ``ROW_BLOCK · QUERY_BLOCK / width`` library frames each.

    A stream's costs must be the same bits alone and among others, and as ``predict`` makes them,
    or its decisions could differ.  A BLAS matrix product does not promise that: OpenBLAS's Haswell
    kernels (AMD Zen 3 runs them) round a query's row differently by where it falls among 16 or
    more queries and by how many there are, a matrix–vector product (gemv) differently again, and
    a product split between two threads differently from one on one.  Products of blocks of 2, 4
    or 8 queries, ``table rows · blockᵀ``, give each query the same bits at every place in the block,
    whatever the block's width, the others and the threads there (OpenBLAS 0.3.31; on the Intel
    Xeons where the engine was built any number of queries did); ``tests/test_batched_engine.py``
    checks the BLAS installed.  So a lone decision is a block of one query and a row of zeros."""
    q = np.ascontiguousarray(queries, dtype=np.float32)
    n, N = len(q), len(table)
    out = np.empty((n, N))
    parts = {}  # a product's output per width, made once a call
    for a in range(0, n, QUERY_BLOCK):
        block = q[a:a + QUERY_BLOCK]
        width = next(w for w in QUERY_WIDTHS if w >= len(block))
        if len(block) < width:
            block = np.concatenate([block, np.zeros((width - len(block), q.shape[1]), np.float32)])
        bt, rows = block.T, ROW_BLOCK * QUERY_BLOCK // width
        part = parts.get(width)
        if part is None:
            part = parts[width] = np.empty((N, width), np.float32)
        for r in range(0, N, rows):
            np.matmul(table[r:r + rows], bt, out=part[r:r + rows])
        out[a:a + width] = part.T[:n - a]
    return out


def percentiles(x: np.ndarray, qs) -> np.ndarray:
    """``np.percentile(x, qs, axis=0)`` (its linear method, the same bits) for a 2-D array without
    NaNs, by a sort: numpy's own takes a path through ``np.unique`` that imports ``numpy.ma`` on
    first use, about 20 ms of every model load (and of a live head's first frame)."""
    x = np.sort(np.asarray(x), axis=0)
    n = len(x)
    v = (n - 1) * (np.asarray(qs, dtype=np.float64) / 100.0)  # numpy's virtual indexes
    lo = np.floor(v)
    t = (v - lo)[:, None]
    lo = np.clip(lo, 0, n - 1).astype(np.intp)
    hi = np.where(v >= n - 1, n - 1, np.minimum(lo + 1, n - 1))
    a, b = x[lo], x[hi]
    d = b - a
    out = a + d * t
    np.subtract(b, d * (1 - t), out=out, where=np.broadcast_to(t >= 0.5, out.shape))
    return out


class Library:
    """The search tables over the library's frames, built once per model: per frame its speech
    descriptor, pose (``poses``, degrees), velocity (``velocities``), the pose change over the next
    ``hop`` frames, where its clip ends (``ends``: the end of its recording, or a jump above
    :data:`MAX_STEP_DEG` in the recorded motion — a tracking glitch is never played) and whether a
    clip may start there (``can_start``: ``hop`` frames must follow before that end); the pose goal's
    ridge regression; and, with :meth:`costs` and :meth:`draw`, a decision's scores and choice.

    Parameters
    ----------
    motion, feats, lengths : the library's motion (degrees), standardised prosody and recording lengths
    starts : bool per frame, where a clip starts (:func:`clip_starts`), or None: found from ``motion``
    own : bool per recording, an adapted model's speaker's own (the others are the base's), or None
    hop, taps, goal_steps, mirror, ridge : the estimator's settings; causal : descriptors from the past only
    shift : frames, ``causal``: each frame's descriptor (and so the goal's regression) is the one
        of the frame ``shift`` later, its speech read that far ahead (a live model's
        ``lookahead_ms``); past a recording's end its last row is repeated (:func:`read_ahead`)
    """

    def __init__(self, motion: np.ndarray, feats: np.ndarray, lengths: np.ndarray, *, starts: np.ndarray | None,
                 own: np.ndarray | None, hop: int, taps: np.ndarray, goal_steps: np.ndarray, mirror: bool,
                 ridge: float, causal: bool, shift: int = 0):
        S, P, V, ok, A, end, Q, mine = [], [], [], [], [], [], [], []
        start, offset, H, shift = 0, 0, int(hop), int(shift)
        #: frames the descriptors read ahead of their frame (``shift``)
        self.shift = shift
        for r, n in enumerate(lengths):
            m = motion[start:start + n].astype(np.float64)
            d = speech_descriptors(read_ahead(feats[start:start + n], shift), taps, causal=causal)[shift:]
            clip = starts[start:start + n] if starts is not None else clip_starts(m)
            bounds = np.append(np.flatnonzero(clip), n)
            clip_end = np.repeat(bounds[1:], np.diff(bounds))  # per frame: where its clip ends
            good = np.arange(n) + H + 1 < clip_end
            ahead = np.clip(np.arange(n)[:, None] + goal_steps[None, :], 0, n - 1)
            nxt = np.clip(np.arange(n)[:, None] + np.arange(1, H + 1)[None, :], 0, n - 1)
            v = np.vstack([m[1:2] - m[:1], np.diff(m, axis=0)])
            q = (v[nxt] ** 2).mean(axis=1)  # (n, 3): mean squared velocity over the next hop (a mirror's too)
            flips = [np.ones(3), np.array([1.0, -1.0, -1.0])] if mirror else [np.ones(3)]
            for f in flips:
                c = m * f
                S.append(d)
                P.append(c)
                A.append(c[ahead] - c[:, None, :])  # (n, len(goal steps), 3): the pose change k frames on
                V.append(v * f)
                Q.append(q)
                mine.append(np.full(n, own is None or bool(own[r])))
                ok.append(good)
                end.append(clip_end + offset)
                offset += n
            start += n
        self.descriptors = np.concatenate(S).astype(np.float32)
        self.poses = np.concatenate(P)
        self.velocities = np.concatenate(V)
        self.can_start = np.concatenate(ok)
        self.ends = np.concatenate(end)  # where each frame's clip (in its recording's copy) ends
        self._fit_goal(np.concatenate(mine), np.concatenate(Q), np.concatenate(A), float(ridge))
        self._side_by_side()  # built with the library, not by a stream's first decision

    def _fit_goal(self, own: np.ndarray, Q: np.ndarray, A: np.ndarray, ridge: float) -> None:
        """The scales, the ``amount`` table, the pose goal's regression and the scaled tables."""
        # an adapted model's range, posture and goal are the speaker's: fitted on their frames only
        fit = slice(None) if own.all() else own
        #: an adapted model: 1 on the base library's frames (the ones ``base_cost`` is paid on); else None
        self.base_frames = None if own.all() else (~own).astype(np.float64)
        self.pose_sd = np.maximum(self.poses[fit].std(axis=0), 1e-3)
        self.vel_sd = np.maximum(self.velocities[fit].std(axis=0), 1e-4)
        speed2 = (Q / self.vel_sd ** 2).sum(axis=1) / 3.0
        # ``amount``: how much each frame's next hop moves, in SDs of the library's log speed
        ls = np.log(speed2 + 1e-3)
        self.lively = ((ls - ls.mean()) / max(ls.std(), 1e-6)).astype(np.float32)
        path = A / self.pose_sd  # (N, steps, 3)
        moved = path[:, -1, :]
        # the pose path the speech asks for: ridge regression of the pose on the speech around a
        # frame, each axis scaled to the library's SD (a regression predicts the average head)
        X = np.column_stack([self.descriptors.astype(np.float64), np.ones(len(self.descriptors))])[fit]
        reg = ridge * np.eye(X.shape[1])
        reg[-1, -1] = 0.0
        self.goal_weights = np.linalg.solve(X.T @ X + reg, X.T @ self.poses[fit])
        pred_sd = (X @ self.goal_weights).std(axis=0)
        # a goal stays among the poses the library holds (speech unlike any training speech, e.g.
        # the silence before a file's first word, would otherwise ask for a pose no one took)
        self.goal_range = percentiles(self.poses[fit], (1.0, 99.0))
        # axes the speech predicts (with ``mirror``, yaw and roll are predicted as 0: no goal for them)
        self.goal_axes = pred_sd > 0.02 * self.pose_sd
        self.goal_weights *= np.where(self.goal_axes, np.minimum(self.pose_sd / np.maximum(pred_sd, 1e-12), 10.0),
                                      0.0)
        scaled = {"S": self.descriptors, "P": self.poses / self.pose_sd, "V": self.velocities / self.vel_sd,
                  "A": moved, "G": path[:, :, self.goal_axes].reshape(len(path), -1)}
        self.tables = {"Q2": speed2}
        for k, x in scaled.items():
            x = np.ascontiguousarray(x, dtype=np.float32)
            self.tables[k], self.tables[k + "2"] = x, np.einsum("ij,ij->i", x, x, dtype=np.float64)

    def goals(self, desc: np.ndarray) -> np.ndarray:
        """The pose goal ``(T, 3)`` (degrees; 0 on axes without a goal) for speech descriptors
        ``desc`` (:func:`speech_descriptors`): the ridge prediction, clipped to the 1st–99th
        percentile of the library's poses."""
        return np.clip(np.column_stack([desc.astype(np.float64), np.ones(len(desc))]) @ self.goal_weights,
                       *self.goal_range)

    def costs(self, w: Weights, s: np.ndarray, pose: np.ndarray | None, vel: np.ndarray | None,
              goal: np.ndarray | None = None, speaking: float = 1.0, only: int | None = None,
              pause_weight: float | None = None):
        """The cost (with the settings ``w``) of starting a clip at every library frame (or at the
        frame ``only``, a float) for the speech descriptor ``s``, the next pose and velocity the
        motion is heading for, the pose ``goal`` at the goal steps and whether the hop is speech (1)
        or a pause (0); ``pause_weight`` replaces ``w``'s.  Frames where no clip may start cost
        infinity (but ``only``'s own cost is given: the clip playing may go on there).  One
        :class:`Query` through :meth:`costs_many`."""
        c = self.costs_many([Query(w, s, pose, vel, goal, speaking, pause_weight)])[0]
        return float(c[only]) if only is not None else np.where(self.can_start, c, np.inf)

    def costs_many(self, queries: "list[Query]") -> np.ndarray:
        """``(len(queries), N)``: each query's cost of every library frame (no frame masked) — the
        decisions of many streams at once.

        A cost is a weighted sum of squared distances — the speech descriptor's, the goal path's,
        the pose's and the velocity's — plus the pause, ``amount`` and base-library terms.  Each
        distance is expanded (|a|² − 2a·b + |b|²) around the library's stored norms, so a cost is
        ``base + Σ −2w·(table · query) + Σ w|query|²``: the part that depends on the library frame
        alone (the weighted norms and the other terms: :meth:`_base`, one vector per setting), one
        matrix product of the four tables side by side with every query's weighted vectors
        (:func:`products`), and a number per query.  A query's row does not depend on the other
        queries: it is the row the query gets alone."""
        n = len(queries)
        if n == 0:
            return np.zeros((0, len(self.descriptors)))
        table, cols = self._side_by_side()
        ax = self.goal_axes
        qs = np.zeros((n, table.shape[1]), np.float32)
        const = np.zeros(n)
        keys = []
        for i, q in enumerate(queries):
            w = q.w
            parts = [("S", float(w.speech_weight) / len(q.s), q.s)]
            if q.goal is not None and w.target_weight > 0 and q.speaking > 0 and ax.any():
                step = ((q.goal - (q.pose if q.pose is not None else 0.0)) / self.pose_sd)[..., ax].astype(
                    np.float32).ravel()
                parts.append(("G", float(w.target_weight) / len(step), step))
            if q.pose is not None:
                parts.append(("P", float(w.pose_weight) / 3.0, (q.pose / self.pose_sd).astype(np.float32)))
                parts.append(("V", float(w.velocity_weight) / 3.0, (q.vel / self.vel_sd).astype(np.float32)))
            weights = dict.fromkeys("SGPV", 0.0)
            for name, wt, v in parts:
                v = np.asarray(v, dtype=np.float32)
                qs[i, cols[name]] = -2.0 * wt * v
                const[i] += wt * float(v.astype(np.float64) @ v.astype(np.float64))
                weights[name] = wt
            pw = float(w.pause_weight if q.pause_weight is None else q.pause_weight)
            pause = pw * (1.0 - q.speaking) if pw > 0 and q.speaking < 1.0 else 0.0  # in a pause, clips that hold
            lean = AMOUNT_LEAN * float(np.log2(w.amount)) if w.amount > 0 and w.amount != 1 else 0.0
            keys.append((*weights.values(), pause, bool(w.pause_speed), lean, float(w.base_cost)))
        c = products(table, qs)
        c += const[:, None]
        if len(set(keys)) == 1:
            c += self._base(keys[0])[None, :]
        else:
            for i, k in enumerate(keys):
                c[i] += self._base(k)
        return c

    #: :meth:`_base` vectors kept per library (one per setting: weights, pause, amount)
    KEPT_BASES = 64

    def _side_by_side(self) -> tuple[np.ndarray, dict]:
        """The descriptor, goal-path, pose and velocity tables side by side ``(N, D)`` (float32)
        and each one's columns."""
        if getattr(self, "_joined", None) is None:
            t, names, cols, at = self.tables, "SGPV", {}, 0
            for k in names:
                cols[k] = slice(at, at + t[k].shape[1])
                at += t[k].shape[1]
            self._joined = (np.ascontiguousarray(np.hstack([t[k] for k in names]), dtype=np.float32), cols)
        return self._joined

    def _base(self, key: tuple) -> np.ndarray:
        """The part of a cost that depends on the library frame alone, for one setting ``key`` =
        (the four distances' weights, the pause weight in force, pause_speed, the amount's lean,
        base_cost): the weighted norms, the pause term, the amount's lean, the base library's cost."""
        kept = self.__dict__.setdefault("_bases", {})
        base = kept.get(key)
        if base is None:
            t = self.tables
            wS, wG, wP, wV, pause, pause_speed, lean, base_cost = key
            base = wS * t["S2"] + wG * t["G2"] + wP * t["P2"] + wV * t["V2"]
            if pause:
                base += pause * (t["Q2"] if pause_speed else t["A2"] / 3.0)
            if lean:
                base -= lean * self.lively
            if base_cost > 0 and self.base_frames is not None:  # an adapted model prefers the speaker's own
                base += base_cost * self.base_frames
            while len(kept) >= self.KEPT_BASES:
                kept.pop(next(iter(kept)))
            kept[key] = base
        return base

    @staticmethod
    def draw(cost: np.ndarray, rng: np.random.Generator, *, top_k: int, temperature: float, hop: int,
             distinct: bool = False) -> int:
        """One of the ``top_k`` cheapest library frames, drawn with weight exp(−Δcost / temperature);
        ``distinct``: candidates at least ``hop`` frames apart (different movements, not one clip's neighbours)."""
        k = min(int(top_k), int(np.isfinite(cost).sum()))
        if distinct:
            m = min(len(cost), 20 * k)
            pool = np.argpartition(cost, m - 1)[:m]
            pool = pool[np.argsort(cost[pool], kind="stable")]
            keep: list[int] = []
            for j in pool:
                if np.isfinite(cost[j]) and all(abs(int(j) - i) >= int(hop) for i in keep):
                    keep.append(int(j))
                    if len(keep) == k:
                        break
            idx = np.array(keep)
            k = len(idx)
        else:
            idx = cheapest(cost, k)
        w = np.exp(-(cost[idx] - cost[idx[0]]) / float(temperature))
        return int(idx[rng.choice(k, p=w / w.sum())])
