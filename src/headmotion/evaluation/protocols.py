"""Cross-validation of synthesis systems: train per fold, synthesise held-out speech, score
(thesis §5.9 leave-one-recording-out; paper §4.1 train / valid / test split, §4.3 metrics).

:func:`evaluate` builds speaker-dependent folds, fits every system on the fold's training
recordings, synthesises each held-out recording from its audio and scores the result against the
recorded motion with :mod:`.metrics`, each CCA-type score with its circular-shift chance level
from :mod:`.chance`.  It returns an :class:`EvaluationResult` whose ``rows`` are
``{system, recording, metric, value}`` — what :mod:`.report` writes as ``metrics.csv``.

Protocols
---------
``"loo"`` (thesis §5.9)
    One fold per recording: the model is trained on the same speaker's other recordings.
``"split"`` (paper §4.1)
    One fold per speaker: train on ``train`` (and ``valid``, labelled, for systems that stop
    early), test on ``test``; the split comes from the manifest or
    :func:`headmotion.corpus.paper_split`.
``"speakers"`` (leave speakers out; the seeds are silent — issue 14 chooses systems "on held-out
speakers")
    The speakers, in a seeded random order, are dealt round-robin into ``speaker_folds`` groups
    (0 = one group per speaker: leave-one-speaker-out); each fold trains on the other groups'
    recordings and tests on its group's, so no held-out speaker is seen in training.

A single long take (the ZEGGS mocap take) is cut into folds at its pauses first
(:func:`.pause_folds.split_corpus_at_pauses`, ``headmotion evaluate --folds-at-pauses N``); ``loo``
on the parts is then leave-one-fold-out.

Conditions
----------
``ground-truth`` is the held-out recording's own motion (scored against itself: NMSE 0, and the
reference values of FCCA, SD, jerk).  Other anchors (``desync``, ``other-speaker``,
``shaped-noise``, ``still``; :mod:`.anchors`) are fitted on the fold's training recordings and make
their motion with ``motion_for(recording, seed=)``; systems get ``predict(audio, seed=)``.  A
condition declaring that it needs *other* speakers' motion (an anchor's ``needs_other_speakers``,
a system's ``needs_other_speakers`` capability) is fitted on the other speakers' recordings.

Realism (issue 14 §1, :mod:`.realism`)
--------------------------------------
Every condition (the ground truth against itself, giving the reference values) also gets, per
recording: ``band_0_0.5`` … ``band_4_10`` (share of power < 10 Hz per band; ``band_*_ref`` the
ground truth's), ``spectral_l1``, ``sd_pitch|yaw|roll`` (°) and ``sd_ratio_pitch|yaw|roll``,
``drift`` (``drift_ref``), ``speed_mean``, ``speed_hellinger``, ``accel_hellinger``,
``limit_cycle`` (``limit_cycle_ref``), ``saturation`` (share of frames within 1° of the range the
model declares through :meth:`~headmotion.systems.base.Synthesizer.reachable_range`; nan when it
declares none), ``pause_ratio`` (``pause_ratio_ref``; speech mask of
:func:`headmotion.features.vad.speaking_mask`), ``bc`` (``bc_ref``; EMAGE beat consistency with
the speech onsets) and, for systems not declared deterministic (``stochastic="none"``) and
``samples`` ≥ 2, ``diversity`` of ``samples`` predictions for the same speech (seeds derived from
``(seed, recording, system, k)``; the first is the scored prediction).  Pooled over the held-out
recordings (recording ``ALL``): ``fcca_excess_pooled`` / ``fcca_local_excess_pooled`` (mean
excess) and ``fcca_p_pooled`` / ``fcca_local_p_pooled`` (Stouffer's combination of the
per-recording circular-shift p-values, :func:`.realism.stouffer`).  The motions themselves are kept
in :attr:`EvaluationResult.motions` for the realism figures.

Metrics per (system, recording) — names as in ``metrics.csv``
--------------------------------------------------------------
``nmse`` (+ ``nmse_rx|ry|rz``), ``cca_global`` and ``cca_local`` (predicted vs recorded motion,
local over ``window_s`` = 3 s = 300 frames at 100 fps; paper Table 2), ``fcca`` and ``fcca_local`` (thesis eq 4.5
with motion + Δ, since "in all cases we included the first derivative of the trajectory", §4.3.1;
features = the ``features`` set), ``feat_cca_local`` (motion vs features), ``sd_rx..``,
``sdvel_rx..`` (paper Fig 2, rad and rad/s), ``jerk``, ``accel``; every CCA-type score ``m`` also
has ``m_null_mean``, ``m_null_p95``, ``m_p``, ``m_excess`` (score − null mean).  The ground truth
additionally gets ``paper_chance`` (local CCA with the randomised motion of another speaker, drawn
with the seed, resampled to the recording's rate),
``featcca_local[<set>]`` for every feature set on *every* recording of the corpus, held out or
not (paper Table 1, computed by :func:`.feature_table.feature_table`; with ``_null_mean``,
``_excess``, ``_p`` suffixes for its chance level; ``config["splits"]`` / ``result.splits`` say
which recordings are train / valid / test), and per speaker the local/global
CCA against window size (thesis Fig 4.8) as ``winlocal[<s>s]`` / ``winglobal[<s>s]``
(recording ``speaker:<name>``).  A system with the ``embedding`` capability (CCCAE, AE) adds
``embed_cca_local`` — its embedding's local CCA with the recorded motion (paper Table 1 Wav_AE /
Wav_CCCAE rows).

Parallelism and determinism
---------------------------
Folds, and then the corpus-wide feature table (one task per recording: extract every feature set,
score it), run in parallel with joblib (``n_jobs``), or on a Dask cluster when ``scheduler`` is a
scheduler address (``tcp://host:8786``) or a ``distributed.Client`` (:mod:`.parallel`).  Every random choice is
seeded from ``(seed, recording, system)``, so a re-run, any ``n_jobs`` and Dask give identical
numbers.

Libraries considered: scikit-learn's ``cross_validate`` (estimators on arrays, no notion of
recordings, speakers or time series) and ``LeaveOneGroupOut`` (the splits are one line here);
joblib and dask.distributed run the folds.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from ..align import fit_length
from ..corpus import Corpus, leave_one_out, paper_split
from ..errors import LengthMismatchError, ParameterError
from ..types import FeatureTrack, Motion
from . import chance as C
from . import metrics as M
from .feature_table import extract_one, feature_set_name, feature_table
from .parallel import dask_client, run_map
from .parallel import sub_seed as _sub_seed

GROUND_TRUTH = "ground-truth"
#: local CCA window (paper §4.3: 300 frames = 3 s at 100 fps)
DEFAULT_WINDOW_S = 3.0
#: window sizes (s) of thesis Fig 4.8 (2 s to 100 s)
FIG48_WINDOWS_S = (2, 3, 5, 10, 15, 20, 30, 50, 75, 100)
AXES = ("rx", "ry", "rz")


# -- configuration ---------------------------------------------------------------------------
@dataclass(frozen=True)
class FoldTask:
    """Everything one fold needs (picklable: shipped to joblib / Dask workers)."""

    fold: str
    train: Corpus
    test: Corpus
    others: Corpus | None
    systems: tuple
    features: Any
    seed: int
    window_s: float
    n_shifts: int
    trajectory_recording: str | None
    fig48: bool
    strict: bool = False
    samples: int = 4
    realism: bool = True


@dataclass
class EvaluationResult:
    """Rows ``{system, recording, metric, value}`` plus what the figures need."""

    rows: list[dict]
    config: dict
    systems: list[str]
    recordings: list[str]
    trajectories: dict[str, np.ndarray] = field(default_factory=dict)
    trajectory_recording: str | None = None
    trajectory_fps: float = 100.0
    timings: dict = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    speakers: dict[str, str] = field(default_factory=dict)
    #: paper §4.1 split of every corpus recording (labels the paper Table 1 columns)
    splits: dict[str, str] = field(default_factory=dict)
    #: ``{condition: {recording: (T, 3) rotation vectors}}`` of every held-out recording (realism figures)
    motions: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    #: frame rate of each held-out recording's motion
    fps: dict[str, float] = field(default_factory=dict)

    def values(self, system: str, metric: str) -> np.ndarray:
        """All values of ``metric`` for ``system`` over recordings (NaNs kept)."""
        return np.array([r["value"] for r in self.rows if r["system"] == system and r["metric"] == metric],
                        dtype=float)

    def mean(self, system: str, metric: str) -> float:
        v = self.values(system, metric)
        v = v[np.isfinite(v)]
        return float(np.mean(v)) if len(v) else float("nan")

    def metrics(self) -> list[str]:
        seen: dict[str, None] = {}
        for r in self.rows:
            seen.setdefault(r["metric"], None)
        return list(seen)




def _system_spec(s) -> tuple[str, Any]:
    if isinstance(s, str):
        if "[" in s:  # NAME[KEY=VALUE;...] (headmotion.systems.spec)
            from ..systems.spec import SystemFactory, label, parse_system

            name, params = parse_system(s)
            return label(name, params), SystemFactory(name, params)
        return s, None
    if isinstance(s, tuple) and len(s) == 2 and isinstance(s[0], str):
        return s[0], s[1]
    raise ParameterError(f"a system must be a registry name or a (name, factory) pair; got {s!r}")


def _seed_name(name: str, factory) -> str:
    """The name the condition's seeds derive from: a system given with parameters
    (:class:`~headmotion.systems.spec.SystemFactory`, ``mfcc-dnn[drift_share=0.3]``) draws the
    training and synthesis seeds of its plain name, so settings compared in one evaluation differ
    only by the setting (a paired comparison)."""
    from ..systems.spec import SystemFactory

    return factory.name if isinstance(factory, SystemFactory) else name


def _make_condition(name: str, factory, seed: int):
    """A new system or anchor for one fold, its training seed set through the contract."""
    from ..systems.base import Synthesizer, create

    from .anchors import ANCHORS, create_anchor

    if factory is None:
        model = create_anchor(name) if name in ANCHORS else create(name)
    else:
        model = factory()
    if isinstance(model, Synthesizer) and "random_state" in model.get_params():
        model.set_params(random_state=seed)
    return model


def _needs_other_speakers(model) -> bool:
    from ..systems.base import NEEDS_OTHER_SPEAKERS

    from .anchors import Anchor

    if isinstance(model, Anchor):
        return model.needs_other_speakers
    return NEEDS_OTHER_SPEAKERS in model.capabilities


def _has_embedding(model) -> bool:
    from ..systems.base import EMBEDDING

    return EMBEDDING in getattr(model, "capabilities", ())


def _make_motion(model, rec, seed: int) -> Motion:
    from .anchors import Anchor

    if isinstance(model, Anchor):
        return model.motion_for(rec, seed=seed)
    return model.predict(rec.audio, seed=seed)


def _extract(features, audio, fps: float, n_frames: int) -> FeatureTrack | np.ndarray:
    return extract_one(features, audio, fps=fps, n_frames=n_frames)


def _conform(pred: Motion, ref: Motion, system: str, rec_id: str) -> np.ndarray:
    """The prediction as ``(T_ref, 3)`` at the reference rate (resampled, trimmed / edge-padded
    within one frame + 50 ms)."""
    if not isinstance(pred, Motion):
        raise ParameterError(f"system {system!r} returned {type(pred).__name__}, expected a Motion")
    if abs(pred.fps - ref.fps) > 1e-6:
        pred = pred.resample(ref.fps)
    a = pred.rotvec
    T = len(ref)
    tol = 1 + 0.05 * ref.fps
    if abs(len(a) - T) > tol:
        raise LengthMismatchError(
            f"system {system!r} made {len(a)} frames for recording {rec_id!r}, whose motion has {T} "
            f"(tolerance {tol:g} frames)")
    return np.asarray(fit_length(a, T))


# -- scoring ---------------------------------------------------------------------------------------
@M.single_threaded
def score_recording(ref: Motion, pred: np.ndarray, feats, *, window_s: float = DEFAULT_WINDOW_S,
                    n_shifts: int = C.DEFAULT_SHIFTS, seed: int = 0) -> dict[str, float]:
    """All per-recording metrics of one prediction (names in the module docstring).

    Parameters
    ----------
    ref : Motion — recorded motion (T frames)
    pred : array (T, 3) — predicted rotation vectors at ``ref.fps``
    feats : array (T, D) | FeatureTrack — speech features of the recording's audio
    window_s : float — local CCA window in seconds (3 s = the paper's 300 frames at 100 fps)
    """
    fps = float(ref.fps)
    x = np.asarray(ref.rotvec, dtype=float)
    p = np.asarray(pred, dtype=float)
    f, _ = M.as_array(feats, name="features")
    n = min(len(x), len(p), len(f))
    x, p, f = x[:n], p[:n], f[:n]
    out: dict[str, float] = {}
    nm = M.nmse(x, p)
    out["nmse"] = nm.mean
    for ax, v in zip(AXES, nm.per_axis):
        out[f"nmse_{ax}"] = float(v)
    w = max(3, min(int(round(window_s * fps)), n))
    ss = np.random.SeedSequence(seed).generate_state(4)
    r = C.global_cca_null(p, x, n_shifts=n_shifts, seed=int(ss[0]))
    out["cca_global"] = r.score
    out.update(r.as_dict("cca_global_"))
    r = C.local_cca_null(p, x, window=w, n_shifts=n_shifts, seed=int(ss[1]))
    out["cca_local"] = r.score
    out.update(r.as_dict("cca_local_"))
    xd = np.hstack([x, M.deltas(x)])
    pd = np.hstack([p, M.deltas(p)])
    r = C.fcca_null(xd, f, pd, n_shifts=n_shifts, seed=int(ss[2]))
    out["fcca"] = r.score
    out.update(r.as_dict("fcca_"))
    r = C.fcca_null(xd, f, pd, window=w, n_shifts=n_shifts, seed=int(ss[3]))
    out["fcca_local"] = r.score
    out.update(r.as_dict("fcca_local_"))
    out["feat_cca_local"] = M.local_cca(p, f, window=w)
    sd = M.sd_stats(p, fps=fps)
    for ax, v, dv in zip(AXES, sd.sd, sd.sd_velocity):
        out[f"sd_{ax}"] = float(v)
        out[f"sdvel_{ax}"] = float(dv)
    if n >= 4:
        out["jerk"], out["accel"] = M.jerk_accel(p, fps=fps)
    return out


def _rows(system: str, recording: str, values: dict[str, float]) -> list[dict]:
    return [{"system": system, "recording": recording, "metric": k, "value": float(v)} for k, v in values.items()]


@M.single_threaded
def run_fold(task: FoldTask) -> dict:
    """Fit every system on ``task.train``, synthesise and score ``task.test``.

    Returns ``{"rows", "trajectories", "gt" (recording → (motion, features, speaker)), "timings",
    "warnings", "motions" (condition → recording → the scored motion), "samples" (condition →
    recording → the K samples of a stochastic system)}``."""
    out = {"rows": [], "trajectories": {}, "gt": {}, "timings": {}, "warnings": [], "motions": {}, "samples": {}}
    tests = list(task.test)
    t0 = time.perf_counter()
    feats = {rec.id: _extract(task.features, rec.audio, float(rec.motion.fps), len(rec.motion)) for rec in tests}
    out["timings"]["features"] = time.perf_counter() - t0
    if task.realism:
        t0 = time.perf_counter()
        out["context"] = {rec.id: _realism_context(rec, out) for rec in tests}
        out["timings"]["realism context"] = time.perf_counter() - t0
    for rec in tests:
        _score_ground_truth(task, rec, feats[rec.id], out)
    for spec in task.systems:
        name, factory = _system_spec(spec)
        if name != GROUND_TRUTH:
            _run_condition(task, name, factory, tests, feats, out)
    out.pop("context", None)
    return out


def _score_ground_truth(task: FoldTask, rec, feats, out: dict) -> None:
    """The recorded motion's own scores (and the paper's other-speaker chance level)."""
    rseed = _sub_seed(task.seed, rec.id, GROUND_TRUTH)
    win = max(3, min(int(round(task.window_s * rec.motion.fps)), len(rec.motion)))
    vals = score_recording(rec.motion, rec.motion.rotvec, feats, window_s=task.window_s,
                           n_shifts=task.n_shifts, seed=rseed)
    if task.others is not None and len(task.others):
        # paper §4.3.2: another subject's motion (one speaker, drawn with the seed), at this rate
        other_spk = task.others.speakers[rseed % len(task.others.speakers)]
        other = [o.motion if abs(o.motion.fps - rec.motion.fps) < 1e-9 else o.motion.resample(rec.motion.fps)
                 for o in task.others.filter(speaker=other_spk)]
        vals["paper_chance"] = C.paper_chance_score(rec.motion, other, window=win, seed=rseed)
    if task.realism:
        vals.update(_realism_scores(rec, rec.motion.rotvec, out["context"][rec.id]))
        out["motions"].setdefault(GROUND_TRUTH, {})[rec.id] = np.asarray(rec.motion.rotvec, dtype=np.float32)
    out["rows"] += _rows(GROUND_TRUTH, rec.id, vals)
    out["gt"][rec.id] = (np.asarray(rec.motion.rotvec), np.asarray(M.as_array(feats)[0], dtype=np.float32),
                         rec.speaker, float(rec.motion.fps))
    if rec.id == task.trajectory_recording:
        out["trajectories"][GROUND_TRUTH] = np.asarray(rec.motion.rotvec)


def _fit_condition(task: FoldTask, name: str, factory, out: dict):
    """The fitted system or anchor for this fold, or None (skipped or failed, with a warning)."""
    model = _make_condition(name, factory, _sub_seed(task.seed, task.fold, _seed_name(name, factory)))
    train = task.train
    if _needs_other_speakers(model):
        if task.others is None or not len(task.others):
            out["warnings"].append(f"{name}: no other speaker in the corpus; skipped for fold {task.fold}")
            return None
        train = task.others
    t0 = time.perf_counter()
    try:
        # warnings of training (e.g. tws-hier using fewer clusters on a short fold) go into the
        # report, once each, instead of the console
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model.fit(train)
        msgs = list(getattr(model, "fit_warnings_", None) or [])
        for w in caught:
            m = str(w.message) if issubclass(w.category, UserWarning) else f"{w.category.__name__}: {w.message}"
            if m not in msgs:
                msgs.append(m)
        out["warnings"] += [f"{name}, fold {task.fold}: {m.removeprefix(f'{name}: ')}" for m in msgs]
    except Exception as exc:
        if task.strict:
            raise
        out["warnings"].append(
            f"{name} could not be trained for fold {task.fold} ({len(train)} recordings, "
            f"{sum(len(r.motion) / r.motion.fps for r in train):.0f} s): {type(exc).__name__}: {exc}")
        return None
    out["timings"][f"fit:{name}"] = out["timings"].get(f"fit:{name}", 0.0) + time.perf_counter() - t0
    return model


def _embedding_scores(task: FoldTask, model, name: str, rec) -> dict[str, float]:
    """Local CCA of a system's learned embedding with the recorded motion (paper Table 1)."""
    emb = model.embed(rec.audio, fps=float(rec.motion.fps), n_frames=len(rec.motion))
    e, _ = M.as_array(emb)
    e = e[: len(rec.motion)]
    r = C.local_cca_null(rec.motion.rotvec[: len(e)], e,
                         window=max(3, min(int(round(task.window_s * rec.motion.fps)), len(e))),
                         n_shifts=task.n_shifts, seed=_sub_seed(task.seed, rec.id, name, "embed"))
    return {"embed_cca_local": r.score, "embed_cca_local_null_mean": r.null_mean,
            "embed_cca_local_excess": r.excess, "embed_cca_local_p": r.p_value}


def _run_condition(task: FoldTask, name: str, factory, tests, feats, out: dict) -> None:
    """Fit one system or anchor, make and score its motion for every held-out recording."""
    model = _fit_condition(task, name, factory, out)
    if model is None:
        return
    t0 = time.perf_counter()
    seed_name = _seed_name(name, factory)
    for rec in tests:
        rseed = _sub_seed(task.seed, rec.id, seed_name)
        try:
            pred = _conform(_make_motion(model, rec, rseed), rec.motion, name, rec.id)
        except Exception as exc:
            if task.strict:
                raise
            out["warnings"].append(f"{name} failed to synthesise {rec.id}: {type(exc).__name__}: {exc}")
            continue
        vals = score_recording(rec.motion, pred, feats[rec.id], window_s=task.window_s, n_shifts=task.n_shifts,
                               seed=rseed)
        if task.realism:
            try:
                samples = _samples(task, model, name, rec, pred, seed_name=seed_name)
                vals.update(_realism_scores(rec, pred, out["context"][rec.id], limits=_limits_deg(model),
                                            samples=samples))
            except Exception as exc:
                if task.strict:
                    raise
                out["warnings"].append(f"{name}: realism measures on {rec.id}: {type(exc).__name__}: {exc}")
            out["motions"].setdefault(name, {})[rec.id] = np.asarray(pred, dtype=np.float32)
            if samples is not None and len(samples) > 1:
                out["samples"].setdefault(name, {})[rec.id] = [np.asarray(x, dtype=np.float32) for x in samples]
        if _has_embedding(model):
            try:
                vals.update(_embedding_scores(task, model, name, rec))
            except Exception as exc:
                out["warnings"].append(f"{name}.embed on {rec.id}: {type(exc).__name__}: {exc}")
        out["rows"] += _rows(name, rec.id, vals)
        if rec.id == task.trajectory_recording:
            out["trajectories"][name] = pred
    key = f"predict+score:{name}"
    out["timings"][key] = out["timings"].get(key, 0.0) + time.perf_counter() - t0


# -- realism -------------------------------------------------------------------------------------
def _realism_context(rec, out: dict) -> dict:
    """Speech mask at the motion's frames and speech onsets of one held-out recording."""
    from . import realism as R

    ctx: dict = {"mask": None, "onsets": None}
    try:
        ctx["mask"] = R.speech_mask_for(rec.audio, rec.motion)
    except Exception as exc:  # a silent or odd file: the pause measure is nan, the rest goes on
        out["warnings"].append(f"speech mask of {rec.id}: {type(exc).__name__}: {exc}")
    try:
        ctx["onsets"] = R.speech_onsets(rec.audio)
    except Exception as exc:
        out["warnings"].append(f"speech onsets of {rec.id}: {type(exc).__name__}: {exc}")
    return ctx


#: realism keys not written to metrics.csv (the recording's own length)
_REALISM_SKIP = ("n_frames", "seconds")


def _realism_scores(rec, pred: np.ndarray, ctx: dict, *, limits=None, samples=None) -> dict[str, float]:
    from . import realism as R

    fps = float(rec.motion.fps)
    row = R.realism(rec.motion, Motion(np.asarray(pred, dtype=float), fps), speech_mask=ctx.get("mask"),
                    onsets=ctx.get("onsets"), limits_deg=limits, samples=samples)
    # measures without their context (no declared range, no samples, no pause) are left out, not nan
    return {k: float(v) for k, v in row.items() if k not in _REALISM_SKIP and np.isfinite(v)}


def _limits_deg(model) -> np.ndarray | None:
    """The system's declared reachable range in degrees (``(3, 2)``), or None."""
    from ..systems.base import Synthesizer

    if not isinstance(model, Synthesizer):
        return None
    r = model.reachable_range()
    return None if r is None else np.degrees(np.asarray(r, dtype=float).reshape(3, 2))


def _samples(task: FoldTask, model, name: str, rec, first: np.ndarray, *, seed_name: str | None = None
             ) -> list[np.ndarray] | None:
    """``task.samples`` predictions for the recording's speech (the scored one first), or None for
    anchors and systems declared deterministic; seeds from ``seed_name`` (default ``name``)."""
    from ..systems.base import Synthesizer

    if task.samples < 2 or not isinstance(model, Synthesizer):
        return None
    if model.get_params().get("stochastic", None) == "none":
        return None
    out = [first]
    for k in range(1, task.samples):
        m = _make_motion(model, rec, _sub_seed(task.seed, rec.id, seed_name or name, k))
        out.append(_conform(m, rec.motion, name, rec.id))
    return out


def pooled_histogram_rows(motions: dict[str, dict[str, np.ndarray]], references: dict[str, Motion],
                          samples: dict[str, dict[str, list]] | None = None) -> list[dict]:
    """Per condition, recording ``ALL``: Hellinger distance of the speed and acceleration
    histograms pooled over every held-out recording (``speed_hellinger_pooled``,
    ``accel_hellinger_pooled``) — the GENEA numerical evaluations' form, one histogram per
    condition over the whole test set — and the spectral L1 between the test set's mean band
    shares (``spectral_l1_pooled``, :func:`~headmotion.evaluation.realism.pooled_spectral_distance`),
    next to the per-recording medians.

    With ``samples`` (``{condition: {recording: [K motions]}}``, the diversity measure's K
    predictions, the scored one first) a stochastic condition also gets
    ``speed_hellinger_pooled_k``: its histogram over all K samples, i.e. the mean of the K
    samples' histograms, as GENEA's ``hellinger_distance.py`` averages the histograms of a
    condition's numbered runs.  One draw estimates the system's speed distribution with the
    sampling noise of one draw (on these test sets about as large as the target's tolerance,
    ``scripts/diagnosis_i14/speed_hellinger_noise.py``); K draws with 1/K of its variance.
    Anchors (one motion each) have no such row."""
    from . import realism as R

    out = []
    for cond, d in motions.items():
        rids = [rid for rid in d if rid in references]
        if not rids:
            continue
        vals, refs = {}, {}
        for name, fn in (("speed", R.speed), ("accel", R.acceleration)):
            refs[name] = np.concatenate([fn(references[r]) for r in rids])
            cand = np.concatenate([fn(Motion(np.asarray(d[r], dtype=float), float(references[r].fps))) for r in rids])
            vals[f"{name}_hellinger_pooled"] = R.hellinger_values(refs[name], cand)
        ks = (samples or {}).get(cond, {})
        if all(rid in ks for rid in rids):
            cand = np.concatenate([R.speed(Motion(np.asarray(x, dtype=float), float(references[r].fps)))
                                   for r in rids for x in ks[r]])
            vals["speed_hellinger_pooled_k"] = R.hellinger_values(refs["speed"], cand)
        vals["spectral_l1_pooled"] = R.pooled_spectral_distance(
            [references[r] for r in rids], [Motion(np.asarray(d[r], dtype=float), float(references[r].fps)) for r in rids])
        out += _rows(cond, "ALL", vals)
    return out


def pooled_rows(rows: list[dict], systems: Sequence[str], *, n_shifts: int | None = None) -> list[dict]:
    """Per system, recording ``ALL``: mean FCCA / local-FCCA excess over the held-out recordings and
    the Stouffer-combined p-value of their circular-shift tests (their mid-p values with
    ``n_shifts``, :func:`~headmotion.evaluation.realism.stouffer`)."""
    from .realism import stouffer

    out = []
    for s in systems:
        for m in ("fcca", "fcca_local"):
            ex = [r["value"] for r in rows if r["system"] == s and r["metric"] == f"{m}_excess"
                  and r["recording"] != "ALL"]
            ps = [r["value"] for r in rows if r["system"] == s and r["metric"] == f"{m}_p" and r["recording"] != "ALL"]
            ex = [v for v in ex if np.isfinite(v)]
            if not ex:
                continue
            out += _rows(s, "ALL", {f"{m}_excess_pooled": float(np.mean(ex)), f"{m}_p_pooled": stouffer(ps, n_shifts=n_shifts),
                                    f"{m}_n_pooled": float(len(ex))})
    return out


# -- folds -------------------------------------------------------------------------------------
def _with_split(corpus: Corpus, idx: Sequence[int], split: dict[str, str]) -> Corpus:
    """Subset of ``corpus`` whose recordings carry the given split labels."""
    if corpus.root is not None:
        entries = [dataclasses.replace(corpus.entries[i], split=split.get(corpus.entries[i].recording)) for i in idx]
        return Corpus(root=corpus.root, entries=entries, sample_rate=corpus.sample_rate)
    return Corpus([dataclasses.replace(corpus[i], split=split.get(corpus[i].id)) for i in idx],
                  sample_rate=corpus.sample_rate)


def speaker_groups(speakers: Sequence[str], n_folds: int = 0, *, seed: int = 0) -> list[list[str]]:
    """The speakers in a seeded random order dealt round-robin into ``n_folds`` groups (0 or ≥ the
    number of speakers: one group per speaker)."""
    spk = sorted(set(speakers))
    if n_folds < 0:
        raise ParameterError(f"speaker folds must be ≥ 0; got {n_folds}")
    k = len(spk) if n_folds == 0 else min(n_folds, len(spk))
    order = [spk[i] for i in np.random.default_rng(seed).permutation(len(spk))]
    return [sorted(order[i::k]) for i in range(k)]


def make_folds(corpus: Corpus, protocol: str = "loo", *, seed: int = 0,
               speaker_folds: int = 0) -> list[tuple[str, Corpus, Corpus, Corpus | None]]:
    """``(fold name, train, test, other speakers)`` for ``protocol`` ``"loo"``, ``"split"`` or
    ``"speakers"`` (``speaker_folds`` groups; 0 = leave-one-speaker-out)."""
    entries = corpus.entries
    def others_of(spk):
        idx = [i for i, e in enumerate(entries) if e.speaker != spk]
        return corpus.subset(idx) if idx else None
    folds = []
    if protocol == "loo":
        for rid, train, test in leave_one_out(corpus, per_speaker=True):
            spk = test.entries[0].speaker
            folds.append((rid, train, test, others_of(spk)))
        if not folds:
            raise ParameterError("leave-one-out needs a speaker with at least 2 recordings")
    elif protocol == "split":
        split = paper_split(corpus, seed=seed)
        for spk in corpus.speakers:
            tr = [i for i, e in enumerate(entries) if e.speaker == spk and split.get(e.recording) in ("train", "valid")]
            te = [i for i, e in enumerate(entries) if e.speaker == spk and split.get(e.recording) == "test"]
            if not tr or not te:
                continue
            folds.append((spk, _with_split(corpus, tr, split), _with_split(corpus, te, split), others_of(spk)))
        if not folds:
            raise ParameterError("the split protocol found no speaker with both train and test recordings")
    elif protocol == "dataset":
        from .dataset_split import dataset_split_folds

        folds = dataset_split_folds(corpus)
    elif protocol == "speakers":
        groups = speaker_groups(corpus.speakers, speaker_folds, seed=seed)
        if len(groups) < 2:
            raise ParameterError(f"leaving speakers out needs at least 2 speakers; the corpus has {len(groups)}")
        for g in groups:
            te = [i for i, e in enumerate(entries) if e.speaker in g]
            tr = [i for i, e in enumerate(entries) if e.speaker not in g]
            name = g[0] if len(g) == 1 else f"{g[0]}+{len(g) - 1}"
            folds.append((name, corpus.subset(tr), corpus.subset(te), corpus.subset(tr)))
    else:
        raise ParameterError(f"protocol must be 'loo', 'split', 'dataset' or 'speakers'; got {protocol!r}")
    return folds


@M.single_threaded
def _fig48_rows(gt: dict, windows_s=FIG48_WINDOWS_S) -> list[dict]:
    """Thesis Fig 4.8 per speaker: recordings concatenated, cut into windows of w seconds; local =
    mean CCA over windows, global = CCA over the same windows concatenated."""
    rows = []
    by_spk: dict[str, list] = {}
    for rid in sorted(gt):
        x, f, spk, fps = gt[rid]
        by_spk.setdefault(spk, []).append((x, f, fps))
    for spk, items in by_spk.items():
        fps = items[0][2]
        items = [it for it in items if abs(it[2] - fps) < 1e-6]  # one frame rate per curve
        X = np.vstack([np.hstack([x, M.deltas(x)]) for x, _, _ in items])
        Fe = np.vstack([f for _, f, _ in items])
        for ws in windows_s:
            w = int(round(ws * fps))
            nw = len(X) // w
            if nw < 1:
                continue
            local = M.local_cca(X[: nw * w], Fe[: nw * w], window=w)
            glob = M.cca(X[: nw * w], Fe[: nw * w])
            rows += _rows(GROUND_TRUTH, f"speaker:{spk}", {f"winlocal[{ws}s]": local, f"winglobal[{ws}s]": glob,
                                                           f"winn[{ws}s]": nw})
    return rows


def _longest_held_out(folds) -> str:
    """The held-out recording with the longest motion (the first of equals).  Recordings of an
    on-disk corpus are not loaded for this (only their motion files are read), so the fold tasks
    still ship lazy manifest entries to the workers."""
    from ..errors import HeadMotionError
    from ..io import load_motion

    best, best_s = None, -1.0
    for _, _, test, _ in folds:
        for i, e in enumerate(test.entries):
            try:
                m = test[i].motion if test.root is None else load_motion(test.root / e.motion)
                secs = len(m) / float(m.fps)
            except HeadMotionError:  # the fold will report it
                secs = 0.0
            if best is None or secs > best_s:
                best, best_s = e.recording, secs
    return best


def evaluate(corpus: Corpus, systems: Sequence, *, protocol: str = "loo", features="f0e", n_jobs: int = 1,
             scheduler=None, seed: int = 0, window_s: float = DEFAULT_WINDOW_S, n_shifts: int = C.DEFAULT_SHIFTS,
             feature_sets: Sequence[str] | None = None, trajectory_recording: str | None = None,
             fig48: bool = True, strict: bool = False, progress: Callable | None = None, samples: int = 4,
             realism: bool = True, speaker_folds: int = 0) -> EvaluationResult:
    """Cross-validate ``systems`` on ``corpus`` (see the module docstring).

    Parameters
    ----------
    corpus : Corpus
    systems : sequence of registry names (``"tws-hier"``, ``"shaped-noise"``, …) or
        ``(name, factory)`` pairs where ``factory(**maybe_seed)`` returns a Synthesizer.
        ``"ground-truth"`` is always included.
    protocol : ``"loo"`` | ``"split"`` | ``"dataset"`` | ``"speakers"`` (``speaker_folds`` groups of held-out
        speakers; 0 = one per speaker)
    features : str | callable — the feature set used by FCCA (``f0e`` as in the thesis' choice of
        F0 + energy) or ``callable(audio, fps=, n_frames=) -> FeatureTrack``.
    n_jobs : int — parallel folds with joblib (``-1`` = all cores); ignored with ``scheduler``.
    scheduler : str | distributed.Client | None — run the folds and the feature table (feature
        extraction + scoring per recording) on a Dask cluster.
    seed : int — everything random derives from it.
    window_s : float — local CCA window in seconds (3 s: the paper's 300 frames at 100 fps, §4.3;
        in seconds so that clips at 25 or 30 fps get the same time span).
    n_shifts : int — circular shifts per chance level (≥ 200 recommended).
    feature_sets : feature sets for paper Table 1 (default: every registered set; ``[]`` = none):
        registry names or ``callable(audio, fps=, n_frames=)``.  Scored on *every* recording of the
        corpus (not only held-out ones); :attr:`EvaluationResult.splits` labels each recording
        train / valid / test with :func:`~headmotion.corpus.paper_split` for the report's columns.
    trajectory_recording : recording whose trajectories are kept for the figure (default: the
        longest held-out recording).
    strict : bool — re-raise when a system fails to train or synthesise; by default the failure
        is recorded in ``warnings`` and the evaluation goes on without that system's rows for the
        fold (e.g. a template-warping model cannot be trained from one 10-second clip).
    progress : callable ``(done, total, description)``, optional.
    samples : int — predictions per held-out recording for the diversity measure (systems not
        declared deterministic; < 2 = no diversity).
    realism : bool — compute the realism measures (issue 14 §1) and keep the motions for their
        figures.
    """
    t_start = time.perf_counter()
    specs = [_system_spec(s) for s in systems]
    names = [n for n, _ in specs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ParameterError(f"systems listed twice: {dup}")
    for n, fac in specs:
        if fac is None and n != GROUND_TRUTH:
            from ..systems.base import system_class

            from .anchors import ANCHORS

            if n not in ANCHORS:
                system_class(n)  # unknown names fail now, not in a worker
    specs = [s for s in specs if s[0] != GROUND_TRUTH]
    if feature_sets is None:
        try:
            from .. import features as F

            feature_sets = tuple(F.available())
        except ImportError:
            feature_sets = ()
    feature_sets = tuple(feature_sets)
    folds = make_folds(corpus, protocol, seed=seed, speaker_folds=speaker_folds)
    if trajectory_recording is None:  # the longest held-out recording shows the most
        trajectory_recording = _longest_held_out(folds)
    tasks = [FoldTask(fold=name, train=tr, test=te, others=ot, systems=tuple(specs), features=features, seed=int(seed),
                      window_s=float(window_s), n_shifts=int(n_shifts),
                      trajectory_recording=trajectory_recording, fig48=fig48, strict=bool(strict),
                      samples=int(samples), realism=bool(realism))
             for name, tr, te, ot in folds]
    timings: dict[str, float] = {}
    with dask_client(scheduler) as client:  # one connection for the folds and the feature table
        if progress:
            progress(0, len(tasks), f"{len(tasks)} folds")
        results = run_map(run_fold, tasks, n_jobs=n_jobs, scheduler=client, progress=progress,
                          describe=lambda t: f"fold {t.fold}")
        table: dict = {}
        table_warns: list[str] = []
        if feature_sets:
            # paper Table 1 over every recording of the corpus (train / valid / test columns)
            t0 = time.perf_counter()
            if progress:
                progress(0, len(corpus), "feature table")
            table, table_warns = feature_table(
                corpus, feature_sets, window_s=window_s, n_shifts=n_shifts, seed=int(seed), n_jobs=n_jobs,
                scheduler=client,
                progress=(lambda d, t, desc: progress(d, t, f"feature table {desc}")) if progress else None)
            timings["feature table (wall)"] = time.perf_counter() - t0
    rows: list[dict] = []
    traj: dict[str, np.ndarray] = {}
    gt: dict = {}
    warns: list[str] = []
    motions: dict[str, dict[str, np.ndarray]] = {}
    k_samples: dict[str, dict[str, list]] = {}
    for res in results:  # in fold order, whatever order they finished in
        rows += res["rows"]
        for cond, d in res.get("motions", {}).items():
            motions.setdefault(cond, {}).update(d)
        for cond, d in res.get("samples", {}).items():
            k_samples.setdefault(cond, {}).update(d)
        traj.update(res["trajectories"])
        gt.update(res["gt"])
        warns += res["warnings"]
        for k, v in res["timings"].items():
            timings[k] = timings.get(k, 0.0) + v
    for rid in corpus.ids:
        if table.get(rid):
            rows += _rows(GROUND_TRUTH, rid, table[rid])
    warns += table_warns
    if fig48:
        rows += _fig48_rows(gt)
    rows += pooled_rows(rows, [GROUND_TRUTH] + [n for n, _ in specs], n_shifts=n_shifts)
    recs = [rid for rid in corpus.ids if rid in gt]
    if motions:
        rows += pooled_histogram_rows(motions, {rid: Motion(g[0], g[3]) for rid, g in gt.items()},
                                      samples=k_samples)
    fps = gt[trajectory_recording][3] if trajectory_recording in gt else 100.0
    timings["total_wall"] = time.perf_counter() - t_start
    fs_names = [feature_set_name(f) for f in feature_sets]
    splits = paper_split(corpus, seed=seed)
    config = {"protocol": protocol, "features": feature_set_name(features),
              "seed": seed, "window_s": window_s, "n_shifts": n_shifts, "systems": [GROUND_TRUTH] + [n for n, _ in specs],
              "folds": len(tasks), "feature_sets": fs_names, "splits": splits, "samples": int(samples),
              "speaker_folds": int(speaker_folds) if protocol == "speakers" else None,
              "fold_tests": {t.fold: list(t.test.ids) for t in tasks}}
    return EvaluationResult(rows=rows, config=config, systems=[GROUND_TRUTH] + [n for n, _ in specs], recordings=recs,
                            trajectories=traj, trajectory_recording=trajectory_recording, trajectory_fps=fps,
                            timings=timings, warnings=warns, speakers={e.recording: e.speaker for e in corpus.entries},
                            splits=splits, motions=motions, fps={rid: gt[rid][3] for rid in recs})


__all__ = ["evaluate", "EvaluationResult", "FoldTask", "make_folds", "run_fold", "score_recording", "GROUND_TRUTH",
           "speaker_groups", "pooled_rows", "pooled_histogram_rows"]
