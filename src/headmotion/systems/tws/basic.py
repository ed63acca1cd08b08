"""Basic template-warping synthesis, "tws-basic" (thesis §5.5, Figs 5.7–5.9, Table 5.2).

Training (§5.5, steps 1–4): segment every axis at its extrema; split the segments into speed
classes by their frequency ``1 / (2 d)`` (a segment is half a cycle) with splits at 4.5 Hz and
6.5 Hz (slow / medium / fast, after Hadar et al. 1983 and McClave 2000); per axis and class fit a
GMM over ``[x; y]`` with ``x`` = previous ``(d, a, c)`` of this axis, the other axes' current
``(d, a)``, the speech feature frame at the change, and ``y`` = the new segment's ``(d, a)``.

Synthesis (§5.5, steps 1–6): causal, axis by axis at each next change point
(:class:`~headmotion.systems.tws.generator.Generator`); the class is the one whose GMM gives the input
vector the highest observation probability (or, with ``stochastic`` including "class", sampled
from the normalised probabilities); ``(d, a)`` by maximum likelihood, MMSE (eq 2.9) or sampling
from the conditional; templates alternate; the offset follows from continuity; start from the
mean parameters.

:meth:`TwsBasic.speed_class_confusion` is Table 5.2 (true boundaries given, predict the class).
"""

from __future__ import annotations

import numpy as np

from ...models.gmm import GMMRegression
from ..budget import DEFAULT_TRAIN_HOURS
from .base import POST_PARAMETERS_DOC, TwsBase

#: frequency splits between slow / medium / fast segments (Hz), thesis §5.5
SPEED_SPLITS_HZ = (4.5, 6.5)
CLASS_NAMES = ("slow", "medium", "fast")


def speed_class(d_seconds: np.ndarray) -> np.ndarray:
    """0 slow, 1 medium, 2 fast from segment durations (half cycles) in seconds."""
    f = 1.0 / (2.0 * np.maximum(np.asarray(d_seconds, dtype=np.float64), 1e-9))
    return np.digitize(f, SPEED_SPLITS_HZ)


class TwsBasic(TwsBase):
    """Basic template-warping synthesis.

    Parameters
    ----------
    features : str or FeatureConfig, default "f0e-live" (the streaming F0 + energy set, 64 ms
        feature latency; model files with "f0e" keep their blocked stream, see :mod:`.generator`)
    fps : float or None (the corpus frame rate)
    n_components : int, GMM components per speed class (fewer when a class has little data)
    method : "ml", "mmse" or "sample" — how (d, a) is taken from the conditional distribution
    stochastic : "none", "choice" (= "class", the speed class), "params" or "both" — what is
        sampled (default "params"; §5.5 modifications; the vocabulary of :mod:`headmotion.systems.base`)
    {post_parameters}
    cross_fit : fit the post stages on synthesis of training speech by models trained on the other
        half of the recordings (False; see :mod:`headmotion.systems.tws.base`)
    feature_block, feature_context : frames per feature block and audio context (streaming)
    seed : default synthesis seed (``predict(seed=None)``)
    random_state : EM initialisation seed (training)
    n_init : EM restarts
    blocked : compute features block by block in ``predict`` too (equals the stream exactly)
    max_train_hours : float or None — on a longer corpus, train on a seeded subsample of its
        recordings of this much speech (4; None = every recording; see :mod:`headmotion.systems.budget`)
    """

    name = "tws-basic"

    def __init__(self, features="f0e-live", *, fps: float | None = None, n_components: int = 4,
                 method: str = "mmse", stochastic: str = "params", min_swing_deg: float = 0.5,
                 soft_limit: bool = True, idle: float = 0.4, log_params: bool = False, speed_shaping: bool = True, cross_fit: bool = False,
                 slow_band_restore: bool = True, amplitude_match: bool = True,
                 feature_block: int = 50, feature_context: int = 20, seed: int | None = 0,
                 random_state: int = 0, n_init: int = 2, blocked: bool = False,
                 max_train_hours: float | None = DEFAULT_TRAIN_HOURS):
        self._store_params(locals())

    @staticmethod
    def _x(prev, others, frame):
        return np.hstack([prev, others, frame])

    def _fit_axes(self, data, progress=None):
        self.gmms_ = {}
        for j in range(3):
            a = data[j].arrays()
            X = self._x(a["prev"], a["others"], a["frame"])
            cls = speed_class(a["y"][:, 0])
            for c in range(3):
                idx = cls == c
                n = int(idx.sum())
                if n < X.shape[1] + 4:  # too few to estimate a covariance: class unavailable
                    continue
                M = int(max(1, min(self.n_components, n // (10 * (X.shape[1] + 2)))))
                g = GMMRegression(M, n_init=self.n_init, random_state=self.random_state, max_iter=50)
                self.gmms_[(j, c)] = g.fit(X[idx], self._y_in(a["y"][idx]))
            if not any((j, c) in self.gmms_ for c in range(3)):
                g = GMMRegression(1).fit(X, self._y_in(a["y"]))
                self.gmms_[(j, 0)] = g
            if progress:
                progress(j + 1, 3, f"axis {j}: {sum(1 for c in range(3) if (j, c) in self.gmms_)} speed classes")

    def _classes(self, j):
        return [c for c in range(3) if (j, c) in self.gmms_]

    def _class_scores(self, j: int, X: np.ndarray) -> tuple[list[int], np.ndarray]:
        cl = self._classes(j)
        return cl, np.stack([self.gmms_[(j, c)].log_likelihood_x(X) for c in cl], axis=1)

    def _choose(self, j, template, state, F, t, rng):  # noqa: ARG002  (the template does not pick the class)
        x = self._x(state["prev"], state["others"], F[t])[None]
        cl, ll = self._class_scores(j, x)
        if self._stochastic in ("choice", "both"):
            p = np.exp(ll[0] - ll[0].max())
            c = cl[int(rng.choice(len(cl), p=p / p.sum()))]
        else:
            c = cl[int(np.argmax(ll[0]))]
        method = "sample" if self._stochastic in ("params", "both") else self.method
        y = self.gmms_[(j, c)].predict(x, method=method, rng=rng)[0]
        return self._y_out(y)

    def speed_class_confusion(self, corpus) -> np.ndarray:
        """Table 5.2: rows true class, columns predicted (counts), given the true boundaries."""
        data = self._change_points(corpus)
        conf = np.zeros((3, 3), dtype=np.int64)
        for j in range(3):
            a = data[j].arrays()
            if not len(a["y"]):
                continue
            X = self._x(a["prev"], a["others"], a["frame"])
            cl, ll = self._class_scores(j, X)
            pred = np.asarray(cl)[np.argmax(ll, axis=1)]
            np.add.at(conf, (speed_class(a["y"][:, 0]), pred), 1)
        return conf

    def _model_state(self):
        arrays, keys = {}, []
        for (j, c), g in self.gmms_.items():
            arrays.update(g.to_arrays(f"gmm_{j}_{c}_"))
            keys.append([j, c])
        return {"gmm_keys": keys}, arrays

    def _load_model_state(self, config, arrays):
        self.gmms_ = {(int(j), int(c)): GMMRegression.from_arrays(arrays, f"gmm_{j}_{c}_")
                      for j, c in config["gmm_keys"]}



if TwsBasic.__doc__:  # None under python -OO
    TwsBasic.__doc__ = TwsBasic.__doc__.replace("{post_parameters}", POST_PARAMETERS_DOC)

__all__ = ["TwsBasic", "speed_class", "SPEED_SPLITS_HZ", "CLASS_NAMES"]
