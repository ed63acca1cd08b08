"""Hierarchical template-warping synthesis, "tws-hier" (thesis §5.6–5.8, Tables 5.5–5.7,
Figs 5.10–5.13).

Three layers per axis and template (rising / falling; templates alternate, so the next one is
known at every change point):

1. **Clusters** (§5.6.1, §5.7.2): k-means with random restarts (Euclidean, unweighted means) over
   standardised vectors of the new and previous warping parameters of this axis, the other axes'
   current parameters and the 10 speech frames before the change.  ``n_clusters=None`` chooses k
   by G-means (Hamerly & Elkan 2003, :mod:`headmotion.models.gmeans`); the thesis found 3–4 and
   used 4 for everything, the default here.  Clusters are indexed by increasing size (the last
   is the most frequent), as in Tables 5.6–5.7.
2. **Regression** (§5.7.3): per cluster one full-covariance Gaussian over ``[x; (d, a)]`` with
   ``x`` = previous ``(d, a, c)``, the other axes' ``(d, a)``, the speech frame at the change and
   the mean of the 10 frames before it.  The thesis initialised each fit 100 times at random; for a
   single Gaussian EM has one fixed point, the closed-form ML estimate, which is what is computed
   (the BIC of every cluster's Gaussian is recorded in ``fit_info_``, cf. Fig 5.12).
3. **Recognition** (§5.6.2, §5.7.4): per cluster a 5-state left-to-right HMM with diagonal
   covariance over per-frame observations = the speech features of the previous segment (the
   registry's f0e / mfcc already carry Δ and ΔΔ) + the previous warping parameters of this axis and
   the other axes' current parameters (Fig 5.15), constant over the segment; per axis an
   ergodic 5-state HMM over cluster symbols is the "language model" biasing the choice.

Synthesis (§5.8): at each change point the cluster maximising
``Viterbi log-likelihood of the previous segment under the cluster HMM + lm_weight × log P_LM(cluster |
clusters so far)`` is chosen (or sampled from the normalised scores with ``stochastic`` "cluster" /
"both"); the warping parameters come from the cluster's Gaussian by ML (= the conditional mean for
one Gaussian), MMSE or sampling; the template is warped and appended.

Little data (short folds): a cluster's full-covariance regression Gaussian over ``[x; (d, a)]``
(21 dimensions with f0e) is of full rank only with more vectors than dimensions.  So k is first
capped at ``n // (dim x + 4)`` change points, and then, while k-means leaves a cluster with fewer
than ``dim x + 3`` vectors, k-means is re-run with one cluster fewer (down to one).  Every such
reduction is reported with a ``UserWarning`` and in ``fit_warnings_`` (the evaluation protocol
copies it into its report).  With fewer than 2 change points for an axis and template, ``fit``
raises :class:`~headmotion.errors.ParameterError` naming how many there were and how many are needed.

:meth:`TwsHier.cluster_confusion` gives Tables 5.6 (HMM + LM recogniser) and 5.7 (regression
Gaussians alone).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ...errors import ParameterError
from ...models.gmm import GMMRegression
from ...models.hmm import ErgodicLM, HMMBank, LeftToRightHMM
from ..budget import DEFAULT_TRAIN_HOURS
from ..constraints import check_params, whole
from .base import POST_PARAMETERS_DOC, TwsBase
from .vectors import CONTEXT, MAX_HMM_FRAMES, context_frames

AXIS_NAMES = ("rx", "ry", "rz")
TEMPLATE_NAMES = ("rising", "falling")
#: fewest change points per axis and template that can train (a Gaussian needs two vectors)
MIN_CHANGE_POINTS = 2


@dataclass
class Clusters:
    """k-means result for one axis and template: labels per change point, centres in the
    standardised clustering space, the standardisation, cluster sizes (clusters indexed by
    increasing size)."""

    labels: np.ndarray
    centres: np.ndarray
    zmu: np.ndarray
    zsd: np.ndarray
    counts: np.ndarray

    @property
    def k(self) -> int:
        return len(self.centres)


@dataclass
class TemplateModel:
    """The per-cluster models of one axis and template: regression Gaussians (§5.7.3) and
    recognition HMMs (§5.7.4), with the clustering space to assign true clusters."""

    regs: list
    hmms: list
    centres: np.ndarray
    zmu: np.ndarray
    zsd: np.ndarray
    bank: HMMBank = field(init=False)
    n_features: int = 0

    def __post_init__(self):
        self.bank = HMMBank(self.hmms, self.n_features)

    @property
    def k(self) -> int:
        return len(self.regs)


@dataclass
class AxisLM:
    """The ergodic language model of one axis over symbols ``template * K + cluster``."""

    lm: ErgodicLM
    K: int

    def symbol(self, template: int, cluster: int) -> int:
        return template * self.K + cluster


class TwsHier(TwsBase):
    """Hierarchical template-warping synthesis.

    Parameters
    ----------
    features : str or FeatureConfig, default "f0e-live" (see :class:`~headmotion.systems.tws.basic.TwsBasic`)
    fps : float or None
    n_clusters : int or None — clusters per axis and template; None chooses by G-means
    n_states : int, states of the cluster HMMs and the language model (5)
    hmm_iter : int, Baum–Welch iterations (capped for training speed)
    lm_weight : float, weight of the language-model log probability
    method : "ml", "mmse" or "sample"
    stochastic : "none", "choice" (= "cluster"), "params" or "both" (default "params": sampled, seeded)
    {post_parameters}
    cross_fit : fit the post stages on synthesis of training speech by models trained on the other
        half of the recordings (True; see :mod:`headmotion.systems.tws.base`)
    feature_block, feature_context, seed, blocked : see :class:`~headmotion.systems.tws.basic.TwsBasic`
    n_init : int, k-means random restarts
    random_state : int, training seed (k-means, HMM initialisation; the budget's draw)
    max_train_hours : see :class:`~headmotion.systems.tws.basic.TwsBasic`
    """

    name = "tws-hier"
    #: feature frames before a change point that ``_choose`` reads (HMM window and context)
    feature_memory = MAX_HMM_FRAMES + CONTEXT
    _with_frames = True

    def __init__(self, features="f0e-live", *, fps: float | None = None, n_clusters: int | None = 4,
                 n_states: int = 5, hmm_iter: int = 10, lm_weight: float = 1.0, method: str = "ml",
                 stochastic: str = "params", min_swing_deg: float = 0.5,
                 soft_limit: bool = True, idle: float = 0.4, log_params: bool = False, speed_shaping: bool = True, cross_fit: bool = True,
                 slow_band_restore: bool = True, amplitude_match: bool = True, feature_block: int = 50,
                 feature_context: int = 20, seed: int | None = 0, n_init: int = 10, random_state: int = 0,
                 blocked: bool = False, max_train_hours: float | None = DEFAULT_TRAIN_HOURS):
        self._store_params(locals())

    def _validate_params(self) -> None:
        super()._validate_params()
        check_params(self, {"n_clusters": [whole(1), None]})  # None: G-means finds the number

    # -- vectors ----------------------------------------------------------------------------
    @staticmethod
    def _xreg(prev, others, frame, ctx, D):
        cm = ctx.reshape(len(ctx), CONTEXT, D).mean(axis=1)
        return np.hstack([prev, others, frame, cm])

    @staticmethod
    def _xclu(y, prev, others, ctx):
        return np.hstack([y, prev, others, ctx])

    # -- training ---------------------------------------------------------------------------
    def _fit_axes(self, data, progress=None):
        """Per axis and template: cluster, then regression + HMM per cluster; per axis the
        language model over the cluster symbols."""
        self.templates_ = [[None, None] for _ in range(3)]
        self.lms_ = []
        self.fit_info_ = {"k": {}, "bic": {}, "counts": {}}
        self.fit_warnings_ = []
        reduced = []  # (axis/template, change points, clusters used, clusters wanted, per-cluster minimum)
        self._fit_observation_scale(data)
        step = 0
        for j in range(3):
            a = data[j].arrays()
            labels = np.zeros(len(a["y"]), dtype=np.int64)
            for tau in (0, 1):
                idx = np.nonzero(a["template"] == tau)[0]
                clusters, k_wanted, min_size = self._cluster(a, idx, j, tau)
                if clusters.k < k_wanted:
                    reduced.append((f"{AXIS_NAMES[j]}{'+-'[tau]}", len(idx), clusters.k, k_wanted, min_size))
                self.templates_[j][tau] = self._fit_template(a, data[j].seg_frames, idx, clusters, j, tau)
                labels[idx] = clusters.labels
                self.fit_info_["k"][f"{j}_{tau}"] = clusters.k
                self.fit_info_["counts"][f"{j}_{tau}"] = clusters.counts.tolist()
                step += 1
                if progress:
                    progress(step, 6, f"axis {j} template {tau}: {clusters.k} clusters")
            self.lms_.append(self._fit_language_model(a["template"], labels, a["rec"], j))
        if reduced:
            self._warn_reduced(reduced)

    def _fit_observation_scale(self, data) -> None:
        """Scale of the "other axes" part of HMM observations (unit variance like the features)."""
        allo = np.vstack([np.hstack([np.asarray(d.prev).reshape(-1, 3), np.asarray(d.others).reshape(-1, 4)])
                          for d in data])
        self.oth_mu_ = allo.mean(axis=0)
        self.oth_sd_ = np.maximum(allo.std(axis=0), 1e-6)

    def _cluster(self, a: dict, idx: np.ndarray, j: int, tau: int) -> tuple[Clusters, int, int]:
        """k-means (§5.6.1) of one axis and template's change points; returns the clusters, the
        number wanted and the smallest size a cluster's regression Gaussian needs."""
        D = self.n_features_
        Z = self._xclu(a["y"][idx], a["prev"][idx], a["others"][idx], a["ctx"][idx])
        zmu, zsd = (Z.mean(axis=0), np.maximum(Z.std(axis=0), 1e-9)) if len(Z) else (0, 1)
        Zs = (Z - zmu) / zsd
        dim_x = self._xreg(a["prev"][idx[:1]], a["others"][idx[:1]], a["frame"][idx[:1]], a["ctx"][idx[:1]], D).shape[1]
        min_per = dim_x + 4
        # a cluster's regression Gaussian over [x; (d, a)] has a full-rank covariance only with
        # more vectors than dimensions
        min_size = dim_x + 2 + 1
        if len(idx) < MIN_CHANGE_POINTS:
            where = f"axis {AXIS_NAMES[j]}, {TEMPLATE_NAMES[tau]} template"
            raise ParameterError(
                f"too little motion to train {self.name}: {where} has {len(idx)} change point(s) in "
                f"{getattr(self, 'train_seconds_', float('nan')):.1f} s of training motion; it needs at "
                f"least {MIN_CHANGE_POINTS} per axis and template ({min_size} per cluster for a full-rank "
                f"regression Gaussian) — give longer recordings or more of them")
        k_wanted = self._wanted_clusters(Zs, min_per)
        labels, centres = self._kmeans_with_minimum(Zs, max(1, min(k_wanted, len(idx) // min_per)), min_size)
        counts = np.bincount(labels, minlength=len(centres))
        order = np.argsort(counts, kind="stable")  # index clusters by increasing size
        remap = np.empty(len(centres), dtype=np.int64)
        remap[order] = np.arange(len(centres))
        return (Clusters(labels=remap[labels], centres=centres[order], zmu=np.asarray(zmu, dtype=np.float64),
                         zsd=np.asarray(zsd, dtype=np.float64), counts=counts[order]), k_wanted, min_size)

    def _wanted_clusters(self, Zs: np.ndarray, min_per: int) -> int:
        """``n_clusters``, or G-means' choice (Hamerly & Elkan 2003) when it is None."""
        if self.n_clusters is None and len(Zs) >= 2 * min_per:
            from ...models.gmeans import gmeans

            k, _, _ = gmeans(Zs, max_k=8, min_size=2 * min_per, random_state=self.random_state)
            return int(k)
        return int(self.n_clusters or 1)

    def _kmeans_with_minimum(self, Zs: np.ndarray, k: int, min_size: int) -> tuple[np.ndarray, np.ndarray]:
        """k-means with ``n_init`` restarts; while a cluster is smaller than ``min_size``, again
        with one cluster fewer (the documented reduction)."""
        from sklearn.cluster import KMeans

        while True:
            if k > 1:
                km = KMeans(k, n_init=self.n_init, random_state=self.random_state).fit(Zs)
                labels, centres = km.labels_, km.cluster_centers_
            else:
                labels, centres = np.zeros(len(Zs), dtype=np.int64), Zs.mean(axis=0, keepdims=True)
            if k == 1 or np.bincount(labels, minlength=k).min() >= min_size:
                return labels, centres
            k -= 1

    def _fit_template(self, a: dict, seg_frames: list, idx: np.ndarray, clusters: Clusters, j: int,
                      tau: int) -> TemplateModel:
        """Per cluster the regression Gaussian (§5.7.3, its BIC in ``fit_info_``) and the
        left-to-right HMM over the previous segment's frames (§5.7.4)."""
        D = self.n_features_
        regs, hmms = [], []
        for c in range(clusters.k):
            sel = idx[clusters.labels == c]
            xc = self._xreg(a["prev"][sel], a["others"][sel], a["frame"][sel], a["ctx"][sel], D)
            g = GMMRegression(1).fit(xc, self._y_in(a["y"][sel]))
            regs.append(g)
            self.fit_info_["bic"][f"{j}_{tau}_{c}"] = g.bic(xc, self._y_in(a["y"][sel]))
            const = (np.hstack([a["prev"][sel], a["others"][sel]]) - self.oth_mu_) / self.oth_sd_
            seqs = [np.hstack([seg_frames[i], np.tile(const[n], (len(seg_frames[i]), 1))]) for n, i in enumerate(sel)]
            hmms.append(LeftToRightHMM(self.n_states, n_iter=self.hmm_iter, random_state=self.random_state)
                        .fit(np.vstack(seqs), [len(q) for q in seqs]))
        return TemplateModel(regs=regs, hmms=hmms, centres=clusters.centres, zmu=clusters.zmu, zsd=clusters.zsd,
                             n_features=D)

    def _fit_language_model(self, templates: np.ndarray, labels: np.ndarray, rec: np.ndarray, j: int) -> AxisLM:
        """The axis's ergodic LM over symbols ``template * K + cluster``, one sequence per recording."""
        K = max(self.templates_[j][tau].k for tau in (0, 1))
        lengths = np.bincount(rec) if len(rec) else np.zeros(0, dtype=np.int64)
        lengths = lengths[lengths > 0]
        lm = ErgodicLM(self.n_states, 2 * K, random_state=self.random_state).fit(templates * K + labels, lengths)
        return AxisLM(lm=lm, K=K)

    def _warn_reduced(self, reduced: list) -> None:
        n = [r[1] for r in reduced]
        msg = (f"{self.name}: too little training data for {max(r[3] for r in reduced)} clusters "
               f"({getattr(self, 'train_seconds_', float('nan')):.1f} s of motion; {min(n)}–{max(n)} change "
               f"points per axis and template, each cluster needs >= {reduced[0][4]} for its regression "
               f"Gaussian): clusters used " + ", ".join(f"{r[0]} {r[2]}" for r in reduced))
        if min(n) < reduced[0][4]:
            msg += "; clusters with fewer vectors than dimensions are regularised (ridge): expect a crude model"
        self.fit_warnings_.append(msg)
        warnings.warn(msg, UserWarning, stacklevel=4)

    # -- synthesis ----------------------------------------------------------------------------
    def _init_generation(self):
        return {"alpha": [self.lms_[j].lm.initial_state() for j in range(3)],
                "first": [True, True, True]}

    def _hmm_scores(self, j, tau, Fseg, prev, others, frame_ll=None):
        bank = self.templates_[j][tau].bank
        o = (np.hstack([prev, others]) - self.oth_mu_) / self.oth_sd_
        return bank.segment_loglik(bank.frame_loglik(Fseg) if frame_ll is None else frame_ll, o)

    def _frame_ll(self, g, j, tau, F, lo, hi):
        """Per-frame HMM emission terms of F[lo:hi], cached per utterance (computed as F grows;
        frames before ``lo`` are dropped: ``lo`` never decreases for a given axis and template, so
        the cache stays bounded on a long stream)."""
        key = (j, tau)
        cache = g.setdefault("frame_ll", {})
        start, have = cache.get(key, (lo, None))
        end = start + (0 if have is None else len(have))
        if end < lo:   # nothing cached is still needed
            start, have, end = lo, None, lo
        if end < len(F):
            new = self.templates_[j][tau].bank.frame_loglik(F[end:])
            have = new if have is None else np.concatenate([have, new])
        if lo - start > 256:
            have = have[lo - start:]
            start = lo
        cache[key] = (start, have)
        return have[lo - start:hi - start]

    def _lm_scores(self, j, tau, alpha, first):
        lmm = self.lms_[j]
        k = self.templates_[j][tau].k
        lp = lmm.lm.prior(alpha, first=first)
        return lp[lmm.symbol(tau, 0): lmm.symbol(tau, k)], lmm.symbol(tau, 0)

    def _choose(self, j, tau, state, F, t, rng):
        g = state["gen"]
        m = self.templates_[j][tau]
        lo = max(int(state["seg_start"]), t - MAX_HMM_FRAMES + 1)
        score = self._hmm_scores(j, tau, None, state["prev"], state["others"],
                                 frame_ll=self._frame_ll(g, j, tau, F, lo, t + 1))
        lms, off = self._lm_scores(j, tau, g["alpha"][j], g["first"][j])
        score = score + self.lm_weight * lms
        if self._stochastic in ("choice", "both"):
            p = np.exp(score - score.max())
            c = int(rng.choice(len(p), p=p / p.sum()))
        else:
            c = int(np.argmax(score))
        g["alpha"][j] = self.lms_[j].lm.update(g["alpha"][j], off + c, first=g["first"][j])
        g["first"][j] = False
        lo_c = t - CONTEXT + 1
        cm = F[lo_c:t + 1].mean(axis=0) if lo_c >= 0 else context_frames(F, t).reshape(CONTEXT, -1).mean(axis=0)
        x = np.concatenate([state["prev"], state["others"], F[t], cm])
        cond = m.regs[c].condition(x[None])
        # one Gaussian: ML = MMSE = the conditional mean mu_y + A (x - mu_x) (eq 2.7)
        if self._stochastic in ("params", "both") or self.method == "sample":
            y = cond.sample(rng)[0]
        else:
            y = cond.means[0, 0]
        return self._y_out(y)

    # -- analysis -----------------------------------------------------------------------------
    def cluster_confusion(self, corpus) -> dict[str, np.ndarray]:
        """Tables 5.6 / 5.7: true cluster (nearest k-means centre) vs the cluster recognised by the
        HMMs + language model (``"hmm"``) and by the regression Gaussians' input likelihood alone
        (``"gmm"``), given the true boundaries; counts summed over axes and templates, clusters
        indexed by increasing training frequency."""
        data = self._change_points(corpus)
        kmax = max(self.templates_[j][t].k for j in range(3) for t in (0, 1))
        conf = {"hmm": np.zeros((kmax, kmax), dtype=np.int64), "gmm": np.zeros((kmax, kmax), dtype=np.int64)}
        D = self.n_features_
        for j in range(3):
            a = data[j].arrays()
            lm = self.lms_[j].lm
            alpha, first, prev_rec = None, True, -1
            for i in range(len(a["y"])):
                if a["rec"][i] != prev_rec:
                    alpha, first, prev_rec = lm.initial_state(), True, a["rec"][i]
                tau = int(a["template"][i])
                m = self.templates_[j][tau]
                z = (self._xclu(a["y"][i:i + 1], a["prev"][i:i + 1], a["others"][i:i + 1], a["ctx"][i:i + 1]) - m.zmu) / m.zsd
                true = int(np.argmin(((m.centres - z) ** 2).sum(axis=1)))
                s = self._hmm_scores(j, tau, data[j].seg_frames[i], a["prev"][i], a["others"][i])
                lms, off = self._lm_scores(j, tau, alpha, first)
                pred_h = int(np.argmax(s + self.lm_weight * lms))
                x = self._xreg(a["prev"][i:i + 1], a["others"][i:i + 1], a["frame"][i:i + 1], a["ctx"][i:i + 1], D)
                pred_g = int(np.argmax([r.log_likelihood_x(x)[0] for r in m.regs]))
                conf["hmm"][true, pred_h] += 1
                conf["gmm"][true, pred_g] += 1
                alpha = lm.update(alpha, off + true, first=first)
                first = False
        return conf

    # -- persistence (array names kept from the first file format) ----------------------------
    def _model_state(self):
        arrays = {"oth_mu": self.oth_mu_, "oth_sd": self.oth_sd_}
        ks = {}
        for j in range(3):
            for tau in (0, 1):
                m = self.templates_[j][tau]
                p = f"m{j}{tau}_"
                ks[f"{j}_{tau}"] = m.k
                arrays[p + "centres"] = m.centres
                arrays[p + "zmu"] = np.atleast_1d(m.zmu)
                arrays[p + "zsd"] = np.atleast_1d(m.zsd)
                for c in range(m.k):
                    arrays.update(m.regs[c].to_arrays(f"{p}reg{c}_"))
                    arrays.update(m.hmms[c].to_arrays(f"{p}hmm{c}_"))
            arrays.update(self.lms_[j].lm.to_arrays(f"lm{j}_"))
            ks[f"lm{j}"] = self.lms_[j].K
        info = {"k": self.fit_info_["k"], "counts": self.fit_info_["counts"],
                "bic": {k: float(v) for k, v in self.fit_info_["bic"].items()}}
        return {"clusters": ks, "fit_info": info}, arrays

    def _load_model_state(self, config, arrays):
        self.oth_mu_ = np.asarray(arrays["oth_mu"], dtype=np.float64)
        self.oth_sd_ = np.asarray(arrays["oth_sd"], dtype=np.float64)
        ks = config["clusters"]
        self.templates_ = [[None, None] for _ in range(3)]
        self.lms_ = []
        for j in range(3):
            for tau in (0, 1):
                p = f"m{j}{tau}_"
                k = int(ks[f"{j}_{tau}"])
                self.templates_[j][tau] = TemplateModel(
                    regs=[GMMRegression.from_arrays(arrays, f"{p}reg{c}_") for c in range(k)],
                    hmms=[LeftToRightHMM.from_arrays(arrays, f"{p}hmm{c}_") for c in range(k)],
                    centres=arrays[p + "centres"], zmu=arrays[p + "zmu"], zsd=arrays[p + "zsd"],
                    n_features=self.n_features_)
            self.lms_.append(AxisLM(lm=ErgodicLM.from_arrays(arrays, f"lm{j}_"), K=int(ks[f"lm{j}"])))
        self.fit_info_ = config.get("fit_info", {})



if TwsHier.__doc__:  # None under python -OO
    TwsHier.__doc__ = TwsHier.__doc__.replace("{post_parameters}", POST_PARAMETERS_DOC)

__all__ = ["TwsHier", "Clusters", "TemplateModel", "AxisLM"]
