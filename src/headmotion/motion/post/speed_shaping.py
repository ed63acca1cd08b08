"""Speed shaping: re-timing a head-motion trajectory so that its speed distribution becomes the
recorded heads' (a stage of the post-processing chain, :mod:`headmotion.motion.post`; neither the
thesis nor the paper re-times; ``docs/decisions/speed-shaping.md``).

Recorded heads hold still and then move fast; a regressor's output and warped half-cosine templates
move evenly.  :func:`speed_map` tabulates the quantile map of a system's own speeds onto the training
heads' at fit, :func:`delivered_speed_map` corrects it in closed loop, and :class:`SpeedShaper`
applies it causally, with state; :func:`product_shaper` is the shaper with the product's settings.

Library considered: none does causal quantile-mapped re-timing; the recursion runs in scipy's
``lfilter`` with state.
"""

from __future__ import annotations

import numpy as np
from ..iir import lfilter  # scipy.signal's, bit for bit, without importing it

#: the speed shaper's window (s) and follow time (s) in the product
SHAPING_LAG_S = 0.04
SHAPING_FOLLOW_S = 0.25
#: prior (s) of the shaper's liveliness adaptation in the product (:class:`SpeedShaper`)
SHAPING_ADAPT_S = 5.0
#: quantiles at which the speed map is tabulated
SPEED_QUANTILES = np.linspace(0.0, 1.0, 51)
#: closed-loop corrections of the speed map (:func:`delivered_speed_map`; 0 = the static map), as
#: le2012 and the template systems fit it (the DNN systems fit the static map)
SPEED_MAP_ITERATIONS = 2


def speeds(rv: np.ndarray, lag: int = 1) -> np.ndarray:
    """Per-frame speed ``|x_t − x_{t−lag}| / lag`` of a ``(T, D)`` array (the first ``lag``
    frames: against frame 0)."""
    rv = np.asarray(rv, dtype=np.float64)
    lag = max(int(lag), 1)
    if len(rv) == 0:
        return np.zeros(0)
    prev = np.vstack([np.repeat(rv[:1], min(lag, len(rv)), 0), rv[:-lag] if len(rv) > lag else rv[:0]])
    return np.linalg.norm(rv - prev, axis=1) / lag


#: largest speed-up of a speed map (the map's output speed is at most this times its input's): a
#: network's output on new speech has sharper transitions than on the frames the map is fitted on,
#: and mapping them up without bound gives speeds no recorded head reaches.  The DNN systems' map
#: from their validation frames and le2012's use it.
SPEED_MAX_GAIN = 1.4
#: the wider bound of maps fitted on synthesis far short of the heads' fast tail: the template
#: systems' (warped half-cosines move evenly) and the DNN systems' cross-fitted map
WIDE_SPEED_MAX_GAIN = 2.0


def speed_map(predicted, target, *, lag: int = 1, quantiles=SPEED_QUANTILES, starts=None,
              max_gain: float | None = SPEED_MAX_GAIN) -> np.ndarray:
    """``(2, Q)`` table mapping the predicted motion's speed quantiles (row 0) to the target
    motion's (row 1), pooled over the lists of ``(T, D)`` arrays (quantile mapping); speeds over
    ``lag`` frames (:func:`speeds`), counted from frame ``max(lag, starts[i])`` on; a speed is
    mapped to at most ``max_gain`` times itself (None: no bound)."""
    st0 = [0] * len(predicted) if starts is None else [int(s) for s in starts]
    sp = np.concatenate([speeds(a, lag)[max(lag, s):] for a, s in zip(predicted, st0)])
    st = np.concatenate([speeds(a, lag)[max(lag, s):] for a, s in zip(target, st0)])
    if len(sp) < 2 or len(st) < 2:
        raise ValueError("speed_map needs at least two speeds on each side")
    qp, qt = np.quantile(sp, quantiles), np.quantile(st, quantiles)
    qp = np.maximum.accumulate(qp + 1e-12 * np.arange(len(qp)))       # strictly increasing for interp
    if max_gain is not None:
        qt = np.minimum(qt, float(max_gain) * qp)
    return np.stack([qp, qt])


def delivered_speed_map(predicted, target, *, fps: float, lag: int = 1, max_gain: float | None = SPEED_MAX_GAIN,
                        iterations: int | None = None, quantiles=SPEED_QUANTILES) -> np.ndarray:
    """:func:`speed_map`, then corrected in closed loop so that :func:`product_shaper` *delivers*
    the target's speed quantiles on ``predicted``: the causal shaper follows the path with a leak
    and adapts to the input's liveliness, so a static quantile map under-delivers the fast tail
    and over-delivers the middle.  Each iteration shapes ``predicted``
    with the current table, measures the delivered quantiles and multiplies the table's output
    row by ``target / delivered`` (kept increasing and within ``max_gain``).  ``iterations``
    None = :data:`SPEED_MAP_ITERATIONS` (read when called); 0 = the static map."""
    table = speed_map(predicted, target, lag=lag, quantiles=quantiles, max_gain=max_gain)
    n = SPEED_MAP_ITERATIONS if iterations is None else int(iterations)
    if n <= 0:
        return table
    st = np.concatenate([speeds(a, lag)[lag:] for a in target])
    want = np.quantile(st, quantiles)
    for _ in range(n):
        out = [product_shaper(table, fps).push(np.asarray(a, dtype=np.float64)) for a in predicted]
        got = np.quantile(np.concatenate([speeds(a, lag)[lag:] for a in out]), quantiles)
        row = table[1] * np.where(got > 1e-12, want / np.maximum(got, 1e-12), 1.0)
        row = np.maximum.accumulate(np.maximum(row, 0.0) + 1e-12 * np.arange(len(row)))
        if max_gain is not None:
            row = np.minimum(row, float(max_gain) * table[0])
        table = np.stack([table[0], row])
    return table


class SpeedShaper:
    """Causal re-timing of a trajectory so that its speed distribution becomes the target's:
    ``x'_t = x'_{t−1} + s_t (x_t − x_{t−1}) + κ (x_{t−1} − x'_{t−1})`` with ``s_t = Q(|v_t|) / |v_t|`` the
    quantile map of :func:`speed_map` and ``κ = 1 / (follow_s · fps)``: fast moves are made
    faster and slow ones slower (holds), and the leak pulls the result back onto the path within
    ``follow_s``.  A first-order recursion run with state (``lfilter`` with ``zi``), so chunked
    pushes give what one push gives.

    With ``adapt_s`` (the product: :data:`SHAPING_ADAPT_S`), the map is looked up at
    ``|v_t| / α_t``, ``α_t`` the running mean of the input's speeds so far (with ``adapt_s``
    seconds of prior at the map's own input mean) over that mean: the map was measured on the
    network's output on training speakers' validation frames, and on a new speaker's speech the
    same network is 10–15 % slower or faster depending on its training seed (held-out speakers of
    the video corpus, median speed 14.1 or 17.1 °/s against 16.2 recorded); the adaptation takes
    that scale out, so what the map sets is the speed distribution (pooled speed Hellinger over
    the held-out speakers 0.074 → 0.064 and 0.066 → 0.058 for the two training seeds)."""

    def __init__(self, table, *, fps: float, follow_s: float = 0.5, lag: int = 1, adapt_s: float | None = None):
        self.table = np.asarray(table, dtype=np.float64)
        self.k = 1.0 / max(float(follow_s) * float(fps), 1.0)
        self.lag = max(int(lag), 1)
        self.hist = None      # the last ``lag`` input frames
        self.zi = None        # lfilter state: (1 − κ) x'_{t−1}
        #: liveliness adaptation: the input's speeds are divided by the ratio of their running mean
        #: (with ``adapt_s`` seconds of prior at the map's own mean) to the map's input mean
        self.prior_n = 0.0 if adapt_s is None else float(adapt_s) * float(fps)
        q = self.table[0]
        self.ref_mean = float((q.sum() - 0.5 * (q[0] + q[-1])) / max(len(q) - 1, 1))  # mean of the quantile function
        self.sum_sp = self.prior_n * self.ref_mean
        self.n_sp = self.prior_n

    def push(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=np.float64)
        n = len(x)
        if n == 0:
            return x.copy()
        if self.hist is None:
            self.hist = np.repeat(x[:1], self.lag, 0)
        ext = np.vstack([self.hist, x])                       # ext[lag + t] = x_t
        L = self.lag
        prev = ext[L - 1:L - 1 + n]
        v = x - prev
        sp = speeds(ext, L)[L:]                                # speed over the last ``lag`` frames
        look = sp
        if self.prior_n > 0:
            cs = np.cumsum(np.concatenate([[self.sum_sp], sp]))[1:]   # sequential: chunking-invariant
            alpha = cs / (self.n_sp + np.arange(1, n + 1)) / max(self.ref_mean, 1e-12)
            self.sum_sp, self.n_sp = float(cs[-1]), self.n_sp + n
            look = sp / alpha
        ratio = np.interp(look, self.table[0], self.table[1]) / np.maximum(sp, 1e-12)
        s = np.where(sp > 1e-12, ratio, 1.0)
        u = self.k * prev + s[:, None] * v
        if self.zi is None:
            self.zi = ((1.0 - self.k) * x[0])[None]
        out, self.zi = lfilter([1.0], [1.0, -(1.0 - self.k)], u, zi=self.zi)
        self.zi = self.zi.reshape(1, -1)
        self.hist = ext[-L:].copy()
        return out


def shaping_lag(fps: float) -> int:
    """The shaper's window in frames at ``fps`` (:data:`SHAPING_LAG_S`)."""
    return max(1, int(round(SHAPING_LAG_S * float(fps))))


def product_shaper(table, fps: float) -> SpeedShaper:
    """A :class:`SpeedShaper` for ``table`` with the product's window, follow time and liveliness
    adaptation (read when called)."""
    return SpeedShaper(table, fps=fps, follow_s=SHAPING_FOLLOW_S, lag=shaping_lag(fps), adapt_s=SHAPING_ADAPT_S)


__all__ = ["SpeedShaper", "speed_map", "delivered_speed_map", "speeds", "shaping_lag", "product_shaper", "SPEED_QUANTILES",
           "SPEED_MAX_GAIN", "WIDE_SPEED_MAX_GAIN", "SHAPING_LAG_S", "SHAPING_FOLLOW_S", "SHAPING_ADAPT_S"]
