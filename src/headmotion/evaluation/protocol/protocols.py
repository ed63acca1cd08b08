"""Cross-validation of synthesis systems beside anchors and model files: fit per fold, make the
motion of held-out speech, score it (thesis §5.9 leave-one-recording-out; paper §4.1 train /
valid / test split, §4.3 metrics).

:func:`evaluate` builds the folds (:mod:`.folds`), fits every condition on each fold's training
recordings, makes its motion for each held-out recording and scores it against the recorded
motion (:mod:`.running`, :mod:`.scoring`; :mod:`.metrics`, each CCA-type score with its
circular-shift chance level from :mod:`.chance`).  It returns an :class:`EvaluationResult`
(:mod:`.results`) whose ``rows`` are ``{system, recording, metric, value}`` — what :mod:`.report`
writes as ``metrics.csv``.

Protocols (:mod:`.folds`)
-------------------------
``"loo"`` (thesis §5.9: leave one recording of the speaker out), ``"split"`` (paper §4.1: train /
valid / test per speaker), ``"speakers"`` (leave groups of speakers out; ``speaker_folds``) and
``"sources"`` (leave each source of the corpus out in turn: the manifest's ``source`` column).
A single long take is cut into folds at its pauses first (:mod:`.pause_folds`, ``headmotion
evaluate --folds-at-pauses N``); ``loo`` on the parts is then leave-one-fold-out.

Conditions (:mod:`.conditions`, :mod:`.condition_specs`)
--------------------------------------------------------
Every condition is evaluated alike: fitted on the fold's training recordings (on the other
speakers' when it declares ``needs_other_speakers``), then asked for the motion of each held-out
recording with a seed.  ``ground-truth`` is the held-out recording's own motion (scored against
itself: NMSE 0, and the reference values of FCCA, SD, jerk); the other anchors (``desync``,
``shifted``, ``other-speaker``, ``shaped-noise``, ``still``; :mod:`.anchors`) make their motion
from the recorded motion; a system is trained on the fold and predicts from the recording's
speech; a model file (``mine.hmz``, or the shipped ``default`` / ``stream``) predicts without
training, the same model in every fold.

Realism (:mod:`.realism`)
-------------------------
Every condition (the ground truth against itself, giving the reference values) also gets, per
recording: ``band_0_0.5`` … ``band_4_10`` (share of power < 10 Hz per band; ``band_*_ref`` the
ground truth's), ``spectral_l1``, ``sd_pitch|yaw|roll`` (°) and ``sd_ratio_pitch|yaw|roll``,
``drift`` (``drift_ref``), ``speed_mean``, ``speed_hellinger``, ``accel_hellinger``,
``limit_cycle`` (``limit_cycle_ref``), ``saturation`` (share of frames within 1° of the range the
model declares through :meth:`~headmotion.systems.base.Synthesizer.reachable_range`; nan when it
declares none), ``pause_ratio`` (``pause_ratio_ref``; speech mask of
:func:`headmotion.features.vad.speaking_mask`), ``bc`` (``bc_ref``; EMAGE beat consistency with
the speech onsets) and, for conditions declared ``sampled`` (systems not declared deterministic) and
``samples`` ≥ 2, ``diversity`` of ``samples`` predictions for the same speech (seeds derived from
``(seed, recording, condition, k)``; the first is the scored prediction).  Pooled over the held-out
recordings (recording ``ALL``): ``fcca_excess_pooled`` / ``fcca_local_excess_pooled`` (mean
excess) and ``fcca_p_pooled`` / ``fcca_local_p_pooled`` (Stouffer's combination of the
per-recording circular-shift p-values, :func:`.realism.stouffer`).  The motions themselves are kept
in :attr:`EvaluationResult.motions` for the realism figures.

Metrics per (condition, recording) — names as in ``metrics.csv``
----------------------------------------------------------------
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
seeded from ``(seed, recording, condition)``, so a re-run, any ``n_jobs`` and Dask give identical
numbers.

Libraries considered: scikit-learn's ``cross_validate`` (estimators on arrays, no notion of
recordings, speakers or time series) and ``LeaveOneGroupOut`` (the splits are one line here);
joblib and dask.distributed run the folds.
"""

from __future__ import annotations

import time
from typing import Callable, Sequence

from ...corpus import Corpus, paper_split
from ...errors import ParameterError
from ..measures import chance as C
from ..measures.speech_sides import parse_sides
from .condition_specs import condition_spec
from .conditions import GROUND_TRUTH
from .feature_table import feature_set_name, feature_table
from .folds import longest_held_out, make_folds, speaker_groups
from .levels import level_specs
from .parallel import dask_client, run_map
from .results import EvaluationResult, assemble
from .running import FoldTask, run_fold
from .scoring import (DEFAULT_WINDOW_S, FIG48_WINDOWS_S, FLOOR, pooled_histogram_rows, pooled_rows,
                      score_recording)



def _feature_sets(feature_sets) -> tuple:
    if feature_sets is None:
        try:
            from ... import features as F

            feature_sets = tuple(F.available())
        except ImportError:
            feature_sets = ()
    return tuple(feature_sets)


def _run_feature_table(corpus, feature_sets, *, window_s, n_shifts, seed, n_jobs, client, progress, timings):
    """Paper Table 1 over every recording of the corpus (train / valid / test columns)."""
    if not feature_sets:
        return {}, []
    t0 = time.perf_counter()
    if progress:
        progress(0, len(corpus), "feature table")
    out = feature_table(corpus, feature_sets, window_s=window_s, n_shifts=n_shifts, seed=int(seed), n_jobs=n_jobs,
                        scheduler=client,
                        progress=(lambda d, t, desc: progress(d, t, f"feature table {desc}")) if progress else None)
    timings["feature table (wall)"] = time.perf_counter() - t0
    return out


def evaluate(corpus: Corpus, systems: Sequence, *, protocol: str = "loo", features="f0e", n_jobs: int = 1,
             scheduler=None, seed: int = 0, window_s: float = DEFAULT_WINDOW_S, n_shifts: int = C.DEFAULT_SHIFTS,
             feature_sets: Sequence[str] | None = None, trajectory_recording: str | None = None,
             fig48: bool = True, strict: bool = False, progress: Callable | None = None, samples: int = 4,
             realism: bool = True, speaker_folds: int = 0, detectability: bool = True,
             speech_sides: Sequence[str] | str | None = None, level: bool = False) -> EvaluationResult:
    """Cross-validate ``systems`` on ``corpus`` (see the module docstring).

    Parameters
    ----------
    corpus : Corpus
    systems : sequence of conditions (:mod:`.condition_specs`): registry names (``"tws-hier"``),
        ``NAME[KEY=VALUE;...]``, anchor names (``"shaped-noise"``, ``"desync"``), shipped model
        names (``"default"``, ``"stream"``), model file paths, or ``(name, factory)`` pairs where
        ``factory()`` returns an unfitted Synthesizer.  ``"ground-truth"`` is always included.
    protocol : ``"loo"`` | ``"split"`` | ``"dataset"`` | ``"speakers"`` (``speaker_folds`` groups of held-out
        speakers; 0 = one per speaker) | ``"sources"`` (one fold per source)
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
    strict : bool — re-raise when a condition fails to train or synthesise; by default the failure
        is recorded in ``warnings`` and the evaluation goes on without that condition's rows for
        the fold (e.g. a template-warping model cannot be trained from one 10-second clip).
    progress : callable ``(done, total, description)``, optional.
    samples : int — motions per held-out recording for the diversity measure (sampled conditions;
        < 2 = no diversity).
    realism : bool — compute the realism measures and keep the motions for their figures.
    detectability : bool — with ``realism``, the classifier two-sample test of every condition
        against the recorded motion (:func:`.detectability.detectability_rows`, recording ``ALL``),
        also with both sides low-passed at 3 Hz (:func:`.detectability.low_pass_rows`); when every
        fold has other speakers, the ``floor`` condition (:class:`.anchors.Floor`: their recorded
        heads) is added after the ground truth and every condition's detectability is reported
        beside it (``detect_floor``, ``detect_above_floor``, ``detect_3hz_floor``, …).
    speech_sides : the speech sides of the cross-speaker coupling (:mod:`..measures.speech_sides`;
        default every one): ``praat`` scores with ``features`` (``xcca``, as before), ``own`` and
        ``energy`` with their own features and projections (``xcca_own``, ``xcca_energy``).
    level : bool — add each ``motion-match`` condition's level, the same library read by Praat
        (:func:`.levels.level_specs`); ``config["levels"]`` says whose level each one is.

    Returns
    -------
    EvaluationResult
    """
    t_start = time.perf_counter()
    specs = [condition_spec(s) for s in systems]  # unknown names fail now, not in a worker
    names = [s.name for s in specs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ParameterError(f"systems listed twice: {dup}")
    specs = [s for s in specs if s.name != GROUND_TRUTH]
    sides = parse_sides(speech_sides)
    levels_of, level_notes = {}, []
    if level:
        twins, levels_of, level_notes = level_specs(specs, corpus)
        clash = sorted({t.name for t in twins} & set(names))
        if clash:
            raise ParameterError(f"systems named like a level: {clash}")
        specs += twins
    conditions = [GROUND_TRUTH] + [s.name for s in specs]
    feature_sets = _feature_sets(feature_sets)
    folds = make_folds(corpus, protocol, seed=seed, speaker_folds=speaker_folds)
    if (detectability and realism and FLOOR not in names
            and all(ot is not None and len(ot) for _, _, _, ot in folds)):
        # the floor of every detectability: other speakers' recorded heads against the held-out ones
        specs.insert(0, condition_spec(FLOOR))
        conditions.insert(1, FLOOR)
    if trajectory_recording is None:  # the longest held-out recording shows the most
        trajectory_recording = longest_held_out(folds)
    tasks = [FoldTask(fold=name, train=tr, test=te, others=ot, systems=tuple(specs), features=features, seed=int(seed),
                      window_s=float(window_s), n_shifts=int(n_shifts),
                      trajectory_recording=trajectory_recording, fig48=fig48, strict=bool(strict),
                      samples=int(samples), realism=bool(realism), speech_sides=sides)
             for name, tr, te, ot in folds]
    timings: dict[str, float] = {}
    with dask_client(scheduler) as client:  # one connection for the folds and the feature table
        if progress:
            progress(0, len(tasks), f"{len(tasks)} folds")
        results = run_map(run_fold, tasks, n_jobs=n_jobs, scheduler=client, progress=progress,
                          describe=lambda t: f"fold {t.fold}")
        table, table_warns = _run_feature_table(corpus, feature_sets, window_s=window_s, n_shifts=n_shifts, seed=seed,
                                                n_jobs=n_jobs, client=client, progress=progress, timings=timings)
    splits = paper_split(corpus, seed=seed)
    config = {"protocol": protocol, "features": feature_set_name(features),
              "seed": seed, "window_s": window_s, "n_shifts": n_shifts, "systems": conditions,
              "folds": len(tasks), "feature_sets": [feature_set_name(f) for f in feature_sets], "splits": splits,
              "samples": int(samples), "speaker_folds": int(speaker_folds) if protocol == "speakers" else None,
              "fold_tests": {t.fold: list(t.test.ids) for t in tasks}, "speech_sides": list(sides),
              "levels": levels_of, "level_notes": level_notes}
    result = assemble(results, corpus=corpus, conditions=conditions, table=table, table_warnings=table_warns,
                      fig48=fig48, n_shifts=n_shifts, trajectory_recording=trajectory_recording, config=config,
                      timings=timings, splits=splits, seed=int(seed),
                      options={"detectability": bool(detectability)})
    result.timings["total_wall"] = time.perf_counter() - t_start
    return result


__all__ = ["evaluate", "EvaluationResult", "FoldTask", "make_folds", "run_fold", "score_recording", "GROUND_TRUTH",
           "speaker_groups", "pooled_rows", "pooled_histogram_rows", "FIG48_WINDOWS_S"]
