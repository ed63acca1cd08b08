"""Scoring one condition's motion against the recorded motion (paper §4.3 metrics; thesis §4.3.1
Forced CCA; the realism measures of :mod:`.realism`), per recording and pooled over the held-out
recordings.

Per recording, a condition's motion passes through :data:`RECORDING_MEASURES` in order, each
``measure(s: RecordingScoring) -> {metric: value}``:

* ``accuracy and coupling`` — :func:`score_recording` (NMSE, global / local CCA, FCCA, feature
  CCA, SD, jerk; every CCA-type score with its circular-shift chance level from :mod:`.chance`);
* ``paper chance`` — the reference condition only (the recording's own motion): the paper's
  chance score, local CCA with another speaker's randomised motion (paper §4.3.2);
* ``realism measures`` — :func:`headmotion.evaluation.measures.realism.realism` (band shares, amplitude,
  drift, speed / acceleration Hellinger, limit cycles, saturation in the condition's declared
  range, pauses, beat consistency, diversity of its samples);
* ``embedding`` — conditions with a learned speech embedding: its local CCA with the motion.

Pooled over a condition's held-out recordings (recording ``ALL``), :data:`POOLED_MEASURES`, each
``measure.fn(p: PooledScoring) -> rows``: :func:`pooled_rows` (mean FCCA excess, Stouffer p) and
:func:`pooled_histogram_rows` (speed / acceleration Hellinger and spectral L1 over the test set) and the detectability test
(:mod:`.detectability`: can a classifier tell the condition's motion from the recorded one?).

A new measure plugs in by appending to one of the two tuples: a per-recording one returns its
metrics for one (condition, recording); a pooled one returns ``{system, recording: "ALL", metric,
value}`` rows.  Both land in ``metrics.csv`` unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from ...align import fit_length
from ...errors import LengthMismatchError, ParameterError
from ...types import Motion
from ..measures import chance as C
from ..measures import metrics as M
from .conditions import GROUND_TRUTH, Condition

#: local CCA window (paper §4.3: 300 frames = 3 s at 100 fps)
DEFAULT_WINDOW_S = 3.0
#: window sizes (s) of thesis Fig 4.8 (2 s to 100 s)
FIG48_WINDOWS_S = (2, 3, 5, 10, 15, 20, 30, 50, 75, 100)
AXES = ("rx", "ry", "rz")


def conform(pred: Motion, ref: Motion, system: str, rec_id: str) -> np.ndarray:
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


def rows_of(system: str, recording: str, values: dict[str, float]) -> list[dict]:
    """``{system, recording, metric, value}`` rows of one set of metrics (``metrics.csv`` rows)."""
    return [{"system": system, "recording": recording, "metric": k, "value": float(v)} for k, v in values.items()]



# -- per recording -------------------------------------------------------------------------------
@dataclass
class RecordingScoring:
    """What the per-recording measures see of one condition's motion for one held-out recording."""

    condition: Condition
    recording: Any
    #: ``(T, 3)`` rotation vectors at the recording's rate (:func:`conform`)
    pred: np.ndarray
    #: speech features of the recording's audio (the FCCA feature set)
    features: Any
    #: the seed of this (recording, condition) (:func:`~headmotion.evaluation.protocol.parallel.sub_seed`)
    seed: int
    #: the evaluation's seed
    base_seed: int
    window_s: float
    n_shifts: int
    #: the other speakers' recordings of the fold (None: none)
    others: Any = None
    #: speech mask and onsets of the recording (:func:`realism_context`); None: no realism measures
    context: dict | None = None
    #: the condition's samples for the recording (the scored one first), or None
    samples: list | None = None
    #: the fold's speech ↔ motion projections fitted on other speakers' recorded heads
    #: (:class:`~.cross_coupling.CrossSpeakerCCA`), or None
    coupling_model: Any = None
    #: the further speech sides (:mod:`~..measures.speech_sides`: ``own``, ``energy``):
    #: ``{side: (projections, the recording's features of that side)}``
    side_couplings: dict | None = None

    @property
    def window(self) -> int:
        """The local CCA window in frames."""
        return max(3, min(int(round(self.window_s * self.recording.motion.fps)), len(self.recording.motion)))


def accuracy_and_coupling(s: RecordingScoring) -> dict[str, float]:
    """:func:`score_recording` of the condition's motion."""
    rec = s.recording
    return score_recording(rec.motion, s.pred, s.features, window_s=s.window_s, n_shifts=s.n_shifts, seed=s.seed)


def paper_chance(s: RecordingScoring) -> dict[str, float]:
    """Paper §4.3.2, for the reference condition: local CCA of the recording's motion with another
    speaker's randomised motion (one speaker, drawn with the seed, resampled to the recording's
    rate)."""
    if not s.condition.reference or s.others is None or not len(s.others):
        return {}
    rec = s.recording
    other_spk = s.others.speakers[s.seed % len(s.others.speakers)]
    other = [o.motion.resample(rec.motion.fps)
             for o in s.others.filter(speaker=other_spk)]
    return {"paper_chance": C.paper_chance_score(rec.motion, other, window=s.window, seed=s.seed)}


#: realism keys not written to metrics.csv (the recording's own length)
_REALISM_SKIP = ("n_frames", "seconds")


def realism_measures(s: RecordingScoring) -> dict[str, float]:
    """The realism measures of :mod:`.realism` (nothing without a realism context)."""
    from ..measures import realism as R

    if s.context is None:
        return {}
    rec = s.recording
    fps = float(rec.motion.fps)
    r = s.condition.reachable_range()
    limits = None if r is None else np.degrees(np.asarray(r, dtype=float).reshape(3, 2))
    row = R.realism(rec.motion, Motion(np.asarray(s.pred, dtype=float), fps), speech_mask=s.context.get("mask"),
                    onsets=s.context.get("onsets"), limits_deg=limits, samples=s.samples)
    # measures without their context (no declared range, no samples, no pause) are left out, not nan
    return {k: float(v) for k, v in row.items() if k not in _REALISM_SKIP and np.isfinite(v)}


def cross_speaker_coupling(s: RecordingScoring) -> dict[str, float]:
    """Cross-speaker coupling (:mod:`.cross_coupling`): the condition's motion scored with the
    fold's projections fitted on other speakers' recorded heads and speech, against the bridge
    shift null (``xcca``, ``xcca_null_mean``, ``xcca_null_p95``, ``xcca_p``, ``xcca_excess``: the
    speech side ``praat``, the FCCA feature set); each further speech side the same with its own
    projections and features (``xcca_own``, ``xcca_own_excess``, …; ``xcca_energy``, …), the same
    null offsets."""
    from .parallel import sub_seed

    out: dict[str, float] = {}
    rec = s.recording
    pred = np.asarray(s.pred, dtype=float)
    sides = ([("xcca", s.coupling_model, s.features)] if s.coupling_model is not None else []) + [
        (f"xcca_{side}", model, feats) for side, (model, feats) in (s.side_couplings or {}).items()]
    for name, model, feats in sides:
        r = model.test(pred, feats, fps=float(rec.motion.fps), n_shifts=s.n_shifts, seed=sub_seed(s.seed, "xcca"))
        out.update({name: r.score, **r.as_dict(f"{name}_")})
    return out


def beat_alignment(s: RecordingScoring) -> dict[str, float]:
    """Beat consistency (BC of BEAT / EMAGE: head angular-speed minima against the speech onsets,
    :func:`~.realism.beat_consistency`) against the same bridge shift null as the coupling scores
    (``bc_null_mean``, ``bc_null_p95``, ``bc_p``, ``bc_excess``; the score itself is ``bc``)."""
    from ..measures import realism as R
    from .parallel import sub_seed

    onsets = None if s.context is None else s.context.get("onsets")
    if onsets is None or len(onsets) == 0:
        return {}
    rec = s.recording
    fps = float(rec.motion.fps)
    p = np.asarray(s.pred, dtype=float)
    if len(p) < 4:
        return {}
    r = C.shift_null(lambda a: R.beat_consistency(R.motion_beats(a, fps=fps), onsets), p, n_shifts=s.n_shifts,
                     seed=sub_seed(s.seed, "bc"))
    return r.as_dict("bc_")


def embedding_scores(s: RecordingScoring) -> dict[str, float]:
    """Local CCA of a condition's learned speech embedding with the recorded motion (paper Table 1
    Wav_AE / Wav_CCCAE rows)."""
    from .parallel import sub_seed

    if not s.condition.embedding:
        return {}
    rec = s.recording
    emb = s.condition.embed(rec.audio, fps=float(rec.motion.fps), n_frames=len(rec.motion))
    e, _ = M.as_array(emb)
    e = e[: len(rec.motion)]
    r = C.local_cca_null(rec.motion.rotvec[: len(e)], e,
                         window=max(3, min(int(round(s.window_s * rec.motion.fps)), len(e))),
                         n_shifts=s.n_shifts, seed=sub_seed(s.base_seed, rec.id, s.condition.name, "embed"))
    return {"embed_cca_local": r.score, "embed_cca_local_null_mean": r.null_mean,
            "embed_cca_local_excess": r.excess, "embed_cca_local_p": r.p_value}


@dataclass(frozen=True)
class Measure:
    """A per-recording measure: ``fn(scoring) -> {metric: value}``.  A ``guarded`` measure that
    fails leaves a warning naming it and the evaluation goes on (with ``strict``, it raises)."""

    name: str
    fn: Callable[[RecordingScoring], dict]
    guarded: bool = True


#: every condition's per-recording measures, in the order their metrics are written
RECORDING_MEASURES: tuple[Measure, ...] = (
    Measure("accuracy and coupling", accuracy_and_coupling, guarded=False),
    Measure("paper chance", paper_chance, guarded=False),
    Measure("realism measures", realism_measures),
    Measure("cross-speaker coupling", cross_speaker_coupling),
    Measure("beat alignment", beat_alignment),
    Measure("embedding", embedding_scores),
)


def realism_context(rec, warnings: list[str]) -> dict:
    """Speech mask at the motion's frames and speech onsets of one held-out recording (a failure
    leaves that part None and a warning)."""
    from ..measures import realism as R

    ctx: dict = {"mask": None, "onsets": None}
    try:
        ctx["mask"] = R.speech_mask_for(rec.audio, rec.motion)
    except Exception as exc:  # a silent or odd file: the pause measure is nan, the rest goes on
        warnings.append(f"speech mask of {rec.id}: {type(exc).__name__}: {exc}")
    try:
        ctx["onsets"] = R.speech_onsets(rec.audio)
    except Exception as exc:
        warnings.append(f"speech onsets of {rec.id}: {type(exc).__name__}: {exc}")
    return ctx


# -- pooled over the held-out recordings ----------------------------------------------------------
@dataclass
class PooledScoring:
    """What the pooled measures see: every fold's rows and the motions of every condition."""

    rows: list[dict]
    #: condition names, the ground truth first
    conditions: Sequence[str]
    #: ``{condition: {recording: (T, 3)}}`` scored motions (empty without realism measures)
    motions: dict
    #: ``{recording: Motion}`` recorded motion of every held-out recording
    references: dict
    #: ``{condition: {recording: [K motions]}}`` samples of the sampled conditions
    samples: dict
    n_shifts: int
    #: the evaluation's seed
    seed: int = 0
    #: switches and settings of optional pooled measures, by name (what ``evaluate`` passes on)
    options: dict = field(default_factory=dict)
    #: ``{recording: fold}`` the fold each held-out recording was held out in
    folds: dict = field(default_factory=dict)

    @property
    def fps(self) -> dict[str, float]:
        """Frame rate of every held-out recording."""
        return {rid: float(m.fps) for rid, m in self.references.items()}


def pooled_histogram_rows(motions: dict[str, dict[str, np.ndarray]], references: dict[str, Motion],
                          samples: dict[str, dict[str, list]] | None = None) -> list[dict]:
    """Per condition, recording ``ALL``: Hellinger distance of the speed and acceleration
    histograms pooled over every held-out recording (``speed_hellinger_pooled``,
    ``accel_hellinger_pooled``) — the GENEA numerical evaluations' form, one histogram per
    condition over the whole test set — and the spectral L1 between the test set's mean band
    shares (``spectral_l1_pooled``, :func:`~headmotion.evaluation.measures.realism.pooled_spectral_distance`),
    next to the per-recording medians.

    With ``samples`` (``{condition: {recording: [K motions]}}``, the diversity measure's K
    predictions, the scored one first) a stochastic condition also gets
    ``speed_hellinger_pooled_k``: its histogram over all K samples, i.e. the mean of the K
    samples' histograms, as GENEA's ``hellinger_distance.py`` averages the histograms of a
    condition's numbered runs.  One draw estimates the system's speed distribution with the
    sampling noise of one draw (on small test sets about as large as the realism target's
    tolerance); K draws with 1/K of its variance.  Conditions that are not sampled (the anchors:
    one motion each) have no such row."""
    from ..measures import realism as R

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
        out += rows_of(cond, "ALL", vals)
    return out


def pooled_rows(rows: list[dict], systems: Sequence[str], *, n_shifts: int | None = None) -> list[dict]:
    """Per system, recording ``ALL``: mean FCCA / local-FCCA / cross-speaker coupling / beat
    alignment excess over the held-out recordings and the Stouffer-combined p-value of their
    circular-shift tests (their mid-p values with ``n_shifts``,
    :func:`~headmotion.evaluation.measures.realism.stouffer`): ``<m>_excess_pooled``, ``<m>_p_pooled``,
    ``<m>_n_pooled`` for ``m`` in :data:`POOLED_TESTS` (``xcca_own`` and ``xcca_energy``: the
    coupling's further speech sides)."""
    from ..measures.realism import stouffer

    out = []
    for s in systems:
        for m in POOLED_TESTS:
            ex = [r["value"] for r in rows if r["system"] == s and r["metric"] == f"{m}_excess"
                  and r["recording"] != "ALL"]
            ps = [r["value"] for r in rows if r["system"] == s and r["metric"] == f"{m}_p" and r["recording"] != "ALL"]
            ex = [v for v in ex if np.isfinite(v)]
            if not ex:
                continue
            out += rows_of(s, "ALL", {f"{m}_excess_pooled": float(np.mean(ex)), f"{m}_p_pooled": stouffer(ps, n_shifts=n_shifts),
                                    f"{m}_n_pooled": float(len(ex))})
    return out


@M.single_threaded
def fig48_rows(gt: dict, windows_s=FIG48_WINDOWS_S) -> list[dict]:
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
            rows += rows_of(GROUND_TRUTH, f"speaker:{spk}", {f"winlocal[{ws}s]": local, f"winglobal[{ws}s]": glob,
                                                           f"winn[{ws}s]": nw})
    return rows




#: the shift-tested scores pooled over recordings by :func:`pooled_rows`
POOLED_TESTS = ("fcca", "fcca_local", "xcca", "xcca_own", "xcca_energy", "bc")


def _pooled_coupling(p: PooledScoring) -> list[dict]:
    return pooled_rows(p.rows, p.conditions, n_shifts=p.n_shifts)


def _pooled_histograms(p: PooledScoring) -> list[dict]:
    return pooled_histogram_rows(p.motions, p.references, samples=p.samples) if p.motions else []


@dataclass(frozen=True)
class PooledMeasure:
    """A measure over each condition's held-out recordings together: ``fn(pooled) -> rows``
    (``{system, recording: "ALL", metric, value}``); its time is reported under ``name``."""

    name: str
    fn: Callable[[PooledScoring], list[dict]]


#: measures pooled over each condition's held-out recordings, in the order their rows are written
#: the detectability test's groups: recordings, a long one cut into parts of this many seconds
DETECT_CHUNK_S = 12.0


def _pooled_detectability(p: PooledScoring) -> list[dict]:
    """The classifier two-sample test of every condition against the recorded motion
    (:mod:`.detectability`), with the ruler's anchors under the ground truth's name."""
    if not p.options.get("detectability", True) or not p.motions or GROUND_TRUTH not in p.motions:
        return []
    from ..detection.detectability import detectability_rows, floor_rows, low_pass_rows

    real = p.motions[GROUND_TRUTH]
    gen = {c: d for c, d in p.motions.items() if c != GROUND_TRUTH}
    rows = detectability_rows(real, gen, p.fps, seed=int(p.seed), ruler=GROUND_TRUTH, chunk_s=DETECT_CHUNK_S,
                              within=p.folds)
    if p.options.get("low_pass_detectability", True):
        rows += low_pass_rows(real, gen, p.fps, seed=int(p.seed), chunk_s=DETECT_CHUNK_S, within=p.folds)
    return rows + floor_rows(rows, floor=FLOOR)


def _pooled_reversals(p: PooledScoring) -> list[dict]:
    """Direction reversals per frame and axis of every condition (the ground truth's: the recorded
    heads'), :func:`~.detectability.reversal_rows`."""
    if not p.motions:
        return []
    from ..detection.detectability import reversal_rows

    return reversal_rows(p.motions, p.fps)


#: the condition whose detectability is the floor (:class:`~.anchors.Floor`)
FLOOR = "floor"

POOLED_MEASURES: tuple[PooledMeasure, ...] = (PooledMeasure("pooled coupling", _pooled_coupling),
                                              PooledMeasure("pooled histograms", _pooled_histograms),
                                              PooledMeasure("detectability", _pooled_detectability),
                                              PooledMeasure("reversals", _pooled_reversals))


__all__ = ["score_recording", "conform", "rows_of", "RecordingScoring", "Measure", "RECORDING_MEASURES",
           "PooledScoring", "PooledMeasure", "POOLED_MEASURES", "POOLED_TESTS", "FLOOR", "pooled_rows", "pooled_histogram_rows", "fig48_rows",
           "realism_context", "DEFAULT_WINDOW_S", "FIG48_WINDOWS_S", "AXES"]
