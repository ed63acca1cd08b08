"""Running one cross-validation fold: fit every condition on the fold's training recordings, make
its motion for every held-out recording and score it (thesis §5.9; paper §4.1, §4.3).

:func:`run_fold` treats every condition alike (:mod:`.conditions`): the ground truth, the anchors,
the systems trained on the fold and the model files scored as they are.  A condition is fitted on
the fold's training recordings, or on the other speakers' when it declares ``needs_other_speakers``;
its motion for a held-out recording comes from ``motion_for(recording, seed=)`` and goes through
the per-recording measures of :mod:`.scoring`.  A condition declared ``sampled`` also gives
``samples`` motions per recording for the diversity measure.

Every seed derives from ``(seed, fold or recording, the condition's seed name[, k])``
(:func:`.parallel.sub_seed`), so serial, joblib and Dask runs give the same numbers.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...corpus import Corpus
from ..measures import metrics as M
from .condition_specs import ConditionSpec
from .conditions import GROUND_TRUTH
from .feature_table import extract_one
from .parallel import sub_seed
from . import scoring as S
from .scoring import RecordingScoring, conform, realism_context, rows_of

#: the reference condition, scored first in every fold
GROUND_TRUTH_SPEC = ConditionSpec(GROUND_TRUTH, "anchor", GROUND_TRUTH, GROUND_TRUTH)


@dataclass(frozen=True)
class FoldTask:
    """Everything one fold needs (picklable: shipped to joblib / Dask workers).  ``systems`` are
    the :class:`~.condition_specs.ConditionSpec` of the conditions besides the ground truth."""

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
    #: the speech sides of the cross-speaker coupling (:mod:`~..measures.speech_sides`): ``praat``
    #: scores with the FCCA feature set (``xcca``), ``own`` and ``energy`` with their own features
    #: and projections (``xcca_own``, ``xcca_energy``)
    speech_sides: tuple = ("praat",)


@M.single_threaded
def run_fold(task: FoldTask) -> dict:
    """Fit every condition on ``task.train``, make and score its motion for ``task.test``.

    Returns ``{"rows", "trajectories", "gt" (recording → (motion, features, speaker, fps)),
    "timings", "warnings", "motions" (condition → recording → the scored motion), "samples"
    (condition → recording → the K samples of a sampled condition)}``."""
    out = {"rows": [], "trajectories": {}, "gt": {}, "timings": {}, "warnings": [], "motions": {}, "samples": {}}
    tests = list(task.test)
    t0 = time.perf_counter()
    feats = {rec.id: extract_one(task.features, rec.audio, fps=float(rec.motion.fps), n_frames=len(rec.motion))
             for rec in tests}
    out["timings"]["features"] = time.perf_counter() - t0
    contexts: dict = {}
    if task.realism:
        t0 = time.perf_counter()
        contexts = {rec.id: realism_context(rec, out["warnings"]) for rec in tests}
        out["timings"]["realism context"] = time.perf_counter() - t0
    for rec in tests:
        out["gt"][rec.id] = (np.asarray(rec.motion.rotvec), np.asarray(M.as_array(feats[rec.id])[0], dtype=np.float32),
                             rec.speaker, float(rec.motion.fps))
    t0 = time.perf_counter()
    coupling = fit_cross_coupling(task, out["warnings"]) if "praat" in task.speech_sides else None
    sided = fit_side_couplings(task, tests, out["warnings"])
    out["timings"]["cross-speaker projections"] = time.perf_counter() - t0
    for spec in (GROUND_TRUTH_SPEC,) + tuple(task.systems):
        run_condition(task, spec, tests, feats, contexts, out, coupling, sided)
    return out


#: speech features of training recordings, kept for the folds run by this process
#: ({(recording, feature set, fps, frames): FeatureTrack}; a recording trains several folds)
_TRAIN_FEATURES: dict = {}


def _features_of(task: FoldTask, rec):
    key = (rec.id, task.features, float(rec.motion.fps), len(rec.motion)) if isinstance(task.features, str) else None
    if key is not None and key in _TRAIN_FEATURES:
        return _TRAIN_FEATURES[key]
    f = extract_one(task.features, rec.audio, fps=float(rec.motion.fps), n_frames=len(rec.motion))
    if key is not None:
        if len(_TRAIN_FEATURES) > 2000:
            _TRAIN_FEATURES.clear()
        _TRAIN_FEATURES[key] = f
    return f


def _side_features_of(task: FoldTask, rec, side: str):
    """A recording's features of a further speech side at its motion's rate (``energy`` taken from
    the FCCA features when they are ``f0e``: the same columns, not read twice)."""
    from ..measures.speech_sides import ENERGY_COLUMNS, side_features

    if side == "energy" and task.features == "f0e":
        return _features_of(task, rec).select(ENERGY_COLUMNS)
    key = (rec.id, f"side:{side}", float(rec.motion.fps), len(rec.motion))
    if key not in _TRAIN_FEATURES:
        if len(_TRAIN_FEATURES) > 2000:
            _TRAIN_FEATURES.clear()
        _TRAIN_FEATURES[key] = side_features(rec.audio, side, fps=float(rec.motion.fps), n_frames=len(rec.motion))
    return _TRAIN_FEATURES[key]


def fit_side_couplings(task: FoldTask, tests, warns: list[str]) -> dict:
    """The further speech sides' projections (``task.speech_sides`` but ``praat``), each fitted on
    the other speakers' recorded heads with its own features, and the held-out recordings'
    features of each: ``{recording: {side: (projections, features)}}`` (empty without other
    speakers; a side that fails leaves a warning)."""
    from ..measures.cross_coupling import CrossSpeakerCCA

    sides = [s for s in task.speech_sides if s != "praat"]
    if not sides or task.others is None or not len(task.others):
        return {}
    out: dict = {rec.id: {} for rec in tests}
    recs = list(task.others)
    for side in sides:
        try:
            model = CrossSpeakerCCA().fit([r.motion for r in recs], [_side_features_of(task, r, side) for r in recs])
            for rec in tests:
                out[rec.id][side] = (model, _side_features_of(task, rec, side))
        except Exception as exc:
            if task.strict:
                raise
            warns.append(f"cross-speaker coupling ({side} side) could not be fitted for fold {task.fold}: "
                         f"{type(exc).__name__}: {exc}")
    return out


def fit_cross_coupling(task: FoldTask, warns: list[str]):
    """The fold's speech ↔ motion projections (:class:`~.cross_coupling.CrossSpeakerCCA`) fitted
    on the recorded heads and speech of the speakers the fold does not hold out (``task.others``:
    the training folds' recordings under ``--protocol speakers``), or None (no other speaker; a
    failure leaves a warning)."""
    from ..measures.cross_coupling import CrossSpeakerCCA

    if task.others is None or not len(task.others):
        return None
    try:
        recs = list(task.others)
        return CrossSpeakerCCA().fit([r.motion for r in recs], [_features_of(task, r) for r in recs])
    except Exception as exc:
        if task.strict:
            raise
        warns.append(f"cross-speaker coupling could not be fitted for fold {task.fold}: {type(exc).__name__}: {exc}")
        return None


def fit_condition(task: FoldTask, spec: ConditionSpec, out: dict):
    """The condition fitted for this fold, or None (skipped or failed, with a warning)."""
    name = spec.name
    condition = spec.make(random_state=sub_seed(task.seed, task.fold, spec.seed_name))
    train = task.train
    if condition.needs_other_speakers:
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
            condition.fit(train)
        msgs = condition.fit_warnings
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
    return condition


def draw_samples(task: FoldTask, condition, spec: ConditionSpec, rec, first: np.ndarray) -> list[np.ndarray] | None:
    """``task.samples`` motions of a sampled condition for the recording (the scored one first),
    seeds ``(seed, recording, seed name, k)``; None for conditions not sampled."""
    if task.samples < 2 or not condition.sampled:
        return None
    out = [first]
    for k in range(1, task.samples):
        m = condition.motion_for(rec, seed=sub_seed(task.seed, rec.id, spec.seed_name, k))
        out.append(conform(m, rec.motion, spec.name, rec.id))
    return out


def _measure(task: FoldTask, scoring: RecordingScoring, vals: dict, out: dict) -> None:
    """Every per-recording measure of :mod:`.scoring` into ``vals`` (a guarded one that fails: a
    warning, unless ``strict``)."""
    for measure in S.RECORDING_MEASURES:
        if not measure.guarded:
            vals.update(measure.fn(scoring))
            continue
        try:
            vals.update(measure.fn(scoring))
        except Exception as exc:
            if task.strict:
                raise
            out["warnings"].append(f"{scoring.condition.name}: {measure.name} on {scoring.recording.id}: "
                                   f"{type(exc).__name__}: {exc}")


def run_condition(task: FoldTask, spec: ConditionSpec, tests, feats: dict, contexts: dict, out: dict,
                  coupling=None, sided: dict | None = None) -> None:
    """Fit one condition, make and score its motion for every held-out recording (``coupling``: the
    fold's cross-speaker projections, :func:`fit_cross_coupling`; ``sided``: those of the further
    speech sides, :func:`fit_side_couplings`)."""
    condition = fit_condition(task, spec, out)
    if condition is None:
        return
    name = spec.name
    t0 = time.perf_counter()
    for rec in tests:
        rseed = sub_seed(task.seed, rec.id, spec.seed_name)
        try:
            pred = conform(condition.motion_for(rec, seed=rseed), rec.motion, name, rec.id)
        except Exception as exc:
            if task.strict:
                raise
            out["warnings"].append(f"{name} failed to synthesise {rec.id}: {type(exc).__name__}: {exc}")
            continue
        samples = None
        if task.realism:
            try:
                samples = draw_samples(task, condition, spec, rec, pred)
            except Exception as exc:
                if task.strict:
                    raise
                out["warnings"].append(f"{name}: samples for {rec.id}: {type(exc).__name__}: {exc}")
        scoring = RecordingScoring(condition=condition, recording=rec, pred=pred, features=feats[rec.id], seed=rseed,
                                   base_seed=task.seed, window_s=task.window_s, n_shifts=task.n_shifts,
                                   others=task.others, context=contexts.get(rec.id),
                                   samples=samples, coupling_model=coupling,
                                   side_couplings=(sided or {}).get(rec.id))
        vals: dict[str, float] = {}
        _measure(task, scoring, vals, out)
        if task.realism:
            out["motions"].setdefault(name, {})[rec.id] = np.asarray(pred, dtype=np.float32)
            if samples is not None and len(samples) > 1:
                out["samples"].setdefault(name, {})[rec.id] = [np.asarray(x, dtype=np.float32) for x in samples]
        out["rows"] += rows_of(name, rec.id, vals)
        if rec.id == task.trajectory_recording:
            out["trajectories"][name] = pred
    key = f"predict+score:{name}"
    out["timings"][key] = out["timings"].get(key, 0.0) + time.perf_counter() - t0


__all__ = ["FoldTask", "run_fold", "fit_condition", "run_condition", "draw_samples", "fit_cross_coupling",
           "fit_side_couplings",
           "GROUND_TRUTH_SPEC"]
