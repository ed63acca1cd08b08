"""Realism of head motion: does it *look* like a head, not only is it tied to speech.

The seeds judge synthesis by coupling (CCA, FCCA, thesis §4.3) and listening tests; they are
silent on objective measures of naturalness.  The measures below come from the gesture-generation
literature where one exists and are otherwise chosen here; each is one function, and
:func:`realism` runs all of them on a (reference, candidate) pair and returns one flat dict for a
metrics.csv row.  Angles are in degrees, times in seconds; motions are
:class:`~headmotion.types.Motion` or arrays ``(T, 3)`` of rotation vectors in radians (pitch, yaw,
roll for small angles) with ``fps`` given.

* :func:`band_shares` — share of the motion power below 10 Hz (all axes summed) in the bands
  0–0.5, 0.5–1.5, 1.5–4 and 4–10 Hz (Welch periodogram, ``scipy.signal.welch``, 8 s Hann
  segments, mean removed); :func:`spectral_distance` is the L1 distance of two share vectors
  (0…2).  Chosen here: real heads have most power below 0.5 Hz (posture shifts), a bobbing
  system in 1.5–4 Hz.  :func:`pooled_spectral_distance` is the same L1 between two *sets* of
  motions (a test set's ground truths and a condition's output): each set's shares are the mean
  of its recordings' shares (every recording weighs alike, whatever its amplitude).  Chosen here,
  as the speed histograms are pooled over a test set: on clips of 4–20 s the
  share below 0.5 Hz of *one* recording rests on 2–4 Welch bins and scatters widely (video
  corpus: 0.52–0.88, 10th–90th percentile, for the recorded heads), so the per-recording L1 is
  mostly that scatter — a constant share vector at the recorded heads' median scores a median
  per-recording L1 of 0.19, another speaker's recorded head 0.20–0.37 — while the pooled L1 says
  whether a system's spectrum has the recorded heads' shape.
* :func:`sd_ratio` — SD per axis over the reference's (paper Fig 2 reports the SD itself).
* :func:`drift` — SD of the 5 s running mean per axis (slow wandering of the mean pose).
* :func:`speed`, :func:`acceleration`, :func:`hellinger` — the per-frame angular speed (°/s) and
  acceleration magnitude (°/s²), and the Hellinger distance of their histograms on shared bins,
  ``H = sqrt(1 − Σ sqrt(p q))`` (0 for identical histograms, 1 for disjoint ones), as the GENEA
  challenge numerical evaluations compare speed histograms (Kucherenko et al. 2021, "GENEA
  Challenge 2020"; github.com/genea-workshop/genea_numerical_evaluations).
* :func:`limit_cycle_index` — chosen here: the highest local maximum of the (unbiased, normalised)
  autocorrelation of each axis's velocity at lags 0.25–2 s; ≈ 1 for a steady oscillation, ≈ 0
  for white noise.  Reported as the maximum over axes and per axis.
* :func:`saturation` — share of frames with any axis within 1° of the model's clip limits.
* :func:`pause_speed_ratio` — mean speed in non-speech stretches ≥ 0.5 s over the mean speed in
  speech, with the speech mask of :func:`headmotion.features.vad.speaking_mask` at the motion's
  rate (:func:`speech_mask_for`).
* :func:`diversity` — mean over pairs of K samples for the same speech of the mean per-frame
  Euclidean distance, in units of the reference's total SD ``sqrt(Σ var)`` (SadTalker, Zhang et al.
  2023, reports the SD of K samples' poses; two independent draws of the reference's own
  distribution give ≈ √2).
* :func:`beat_consistency` — BC as BEAT/EMAGE define it (Liu et al. 2022, 2024; from Bailando's
  beat align score): motion beats are the local minima of the (smoothed) speed, audio beats the
  speech onsets (``librosa.onset.onset_detect``), ``BC = mean over audio beats of exp(−d²/2σ²)``
  with ``d`` the distance to the nearest motion beat.  σ = 0.3 s and the extremum order of 7 frames
  at 30 fps (≈ 0.23 s) follow EMAGE's evaluation setting; both are parameters.
* :func:`coupling` and :func:`pooled_coupling` — FCCA and local CCA of the candidate with the
  speech features, each with its circular-shift chance level
  (:mod:`headmotion.evaluation.measures.chance`); the excesses of all held-out recordings are combined
  into one p-value by Stouffer's method (z_i = Φ⁻¹(1 − p_i), Z = Σ z_i / √n).
* :func:`realism_rows` — the one-liner for ``evaluate``: ``{condition: [motion per recording]}``
  and the ground truths → a list of metrics.csv rows (one per condition and recording) plus one
  ``recording="ALL"`` summary row per condition (medians, the pooled p-values, the pooled
  spectral L1 ``spectral_l1_pooled``);
  :func:`long_rows` turns them into ``evaluate``'s long ``{system, recording, metric, value}``
  rows.

Libraries considered: scipy (Welch, histograms, normal quantiles) and librosa (onsets) are used;
no maintained library implements these head-motion measures as a set.
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from ...errors import ParameterError
from ...motion.bands import BAND_EDGES_HZ, band_names
from ...motion.pauses import pause_mask, pause_speech_speeds, pooled_pause_ratio
from ...types import Motion
from . import metrics as M

BANDS: tuple[tuple[float, float], ...] = tuple(zip((0.0, *BAND_EDGES_HZ), (*BAND_EDGES_HZ, 10.0)))
BAND_NAMES = band_names(top=10.0)  # ("0_0.5", "0.5_1.5", "1.5_4", "4_10"): metrics.csv's band columns
AXES = ("pitch", "yaw", "roll")
DEG = 180.0 / np.pi


# -- input -------------------------------------------------------------------------------------------
def _deg(motion, fps: float | None) -> tuple[np.ndarray, float]:
    a, f = M.as_array(motion, name="motion")
    f = fps if fps is not None else f
    if f is None or f <= 0:
        raise ParameterError("realism measures need the frame rate: pass fps= or a Motion")
    if len(a) < 4:
        raise ParameterError(f"realism measures need at least 4 frames; got {len(a)}")
    return a * DEG, float(f)


# -- spectrum ----------------------------------------------------------------------------------------
def psd(motion, *, fps: float | None = None, segment_s: float = 8.0) -> tuple[np.ndarray, np.ndarray]:
    """Welch power spectral density per axis: ``(freqs (F,), psd (F, D))`` in deg²/Hz."""
    from scipy.signal import welch

    a, f = _deg(motion, fps)
    n = int(min(len(a), max(8, round(segment_s * f))))
    freqs, p = welch(a, fs=f, nperseg=n, detrend="constant", axis=0)
    return freqs, p


def band_shares(motion, *, fps: float | None = None, bands=BANDS, fmax: float = 10.0) -> np.ndarray:
    """Share of the power below ``fmax`` Hz (all axes summed) in each band; sums to 1 (or all 0
    for a still motion)."""
    freqs, p = psd(motion, fps=fps)
    tot = p.sum(axis=1)
    keep = freqs < fmax
    total = tot[keep].sum()
    out = np.zeros(len(bands))
    if total <= 0:
        return out
    for i, (lo, hi) in enumerate(bands):
        sel = (freqs >= lo) & (freqs < hi) & keep
        out[i] = tot[sel].sum() / total
    return out


def spectral_distance(shares_ref, shares_cand) -> float:
    """L1 distance of two band-share vectors (0 identical … 2 disjoint)."""
    return float(np.abs(np.asarray(shares_ref, float) - np.asarray(shares_cand, float)).sum())


def pooled_spectral_distance(references: Sequence, candidates: Sequence, *, fps: float | None = None) -> float:
    """L1 distance between the mean band shares of two sets of motions (see the module
    docstring); 0 for the same set, 2 for sets whose power lies in disjoint bands."""
    if not len(references) or not len(candidates):
        raise ParameterError("pooled_spectral_distance needs at least one motion in each set")
    return mean_shares_distance([band_shares(m, fps=fps) for m in references],
                                [band_shares(m, fps=fps) for m in candidates])


def mean_shares_distance(ref_shares, cand_shares) -> float:
    """L1 distance between the means of two lists of band-share vectors (the pooled spectral
    distance from shares already computed)."""
    return spectral_distance(np.mean(np.asarray(ref_shares, float), axis=0), np.mean(np.asarray(cand_shares, float), axis=0))


# -- amplitude ---------------------------------------------------------------------------------------
def sd_ratio(reference, candidate) -> np.ndarray:
    """SD per axis of the candidate over the reference's (nan where the reference is still)."""
    r = M.as_array(reference, name="reference")[0].std(axis=0)
    c = M.as_array(candidate, name="candidate")[0].std(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r > 0, c / np.where(r > 0, r, 1.0), np.nan)


def drift(motion, *, fps: float | None = None, window_s: float = 5.0) -> np.ndarray:
    """SD per axis (°) of the running mean over ``window_s`` seconds (valid part only; the whole
    mean, i.e. 0, when the motion is shorter than the window)."""
    from scipy.ndimage import uniform_filter1d

    a, f = _deg(motion, fps)
    w = int(round(window_s * f))
    if w >= len(a):
        return np.zeros(a.shape[1])
    m = uniform_filter1d(a, size=w, axis=0, mode="nearest")
    h = w // 2
    return m[h:len(a) - (w - h - 1)].std(axis=0)


# -- speed and acceleration ---------------------------------------------------------------------------
def speed(motion, *, fps: float | None = None) -> np.ndarray:
    """Angular speed per frame (°/s): norm of the first difference of the rotation vector × fps."""
    a, f = _deg(motion, fps)
    return np.linalg.norm(np.diff(a, axis=0), axis=1) * f


def acceleration(motion, *, fps: float | None = None) -> np.ndarray:
    """Acceleration magnitude per frame (°/s²): norm of the second difference × fps²."""
    a, f = _deg(motion, fps)
    return np.linalg.norm(np.diff(a, n=2, axis=0), axis=1) * f * f


def histogram_edges(*values, bins: int = 50, upper_percentile: float = 99.0) -> np.ndarray:
    """Shared bin edges from 0 to the ``upper_percentile`` of the pooled values (the last bin also
    takes everything above)."""
    v = np.concatenate([np.ravel(x) for x in values])
    top = float(np.percentile(v, upper_percentile)) if len(v) else 1.0
    if top <= 0:
        top = float(np.max(v)) if len(v) and np.max(v) > 0 else 1.0
    return np.linspace(0.0, top, bins + 1)


def histogram(values, edges) -> np.ndarray:
    """Normalised histogram of ``values`` on ``edges`` (values above the last edge go in the last
    bin)."""
    v = np.clip(np.ravel(values), edges[0], edges[-1])
    h, _ = np.histogram(v, bins=edges)
    s = h.sum()
    return h / s if s else h.astype(float)


def hellinger(p, q) -> float:
    """Hellinger distance of two histograms (normalised here): 0 identical, 1 disjoint."""
    p = np.asarray(p, float)
    q = np.asarray(q, float)
    if p.shape != q.shape:
        raise ParameterError(f"histograms must have the same bins; got {p.shape} and {q.shape}")
    if p.sum() <= 0 or q.sum() <= 0:
        return float("nan")
    p, q = p / p.sum(), q / q.sum()
    return float(np.sqrt(max(0.0, 1.0 - np.sum(np.sqrt(p * q)))))


def hellinger_values(ref_values, cand_values, *, bins: int = 50) -> float:
    """Hellinger distance of two samples' histograms on shared bins (:func:`histogram_edges` over
    the reference's values)."""
    edges = histogram_edges(ref_values, bins=bins)
    return hellinger(histogram(ref_values, edges), histogram(cand_values, edges))


# -- limit cycles -------------------------------------------------------------------------------------
def autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """Unbiased normalised autocorrelation of a 1-D signal at lags 0..max_lag (FFT)."""
    x = np.asarray(x, float) - np.mean(x)
    n = len(x)
    var = np.dot(x, x) / n
    if var <= 0:
        return np.zeros(max_lag + 1)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    f = np.fft.rfft(x, size)
    ac = np.fft.irfft(f * np.conj(f), size)[:max_lag + 1]
    return ac / (n - np.arange(max_lag + 1)) / var


def limit_cycle_index(motion, *, fps: float | None = None, lags_s=(0.25, 2.0)) -> tuple[float, np.ndarray]:
    """Highest local maximum of each axis's velocity autocorrelation at lags in ``lags_s``.

    Returns ``(max over axes, per axis (D,))``; an axis without a local maximum in the range (or
    a still one) scores 0, negative peaks count as 0."""
    a, f = _deg(motion, fps)
    v = np.diff(a, axis=0)
    lo = max(1, int(round(lags_s[0] * f)))
    hi = min(len(v) - 2, int(round(lags_s[1] * f)))
    per = np.zeros(a.shape[1])
    if hi <= lo:
        return 0.0, per
    for j in range(a.shape[1]):
        ac = autocorrelation(v[:, j], hi + 1)
        seg = ac[lo - 1:hi + 2]
        peaks = [seg[i] for i in range(1, len(seg) - 1) if seg[i] >= seg[i - 1] and seg[i] > seg[i + 1]]
        per[j] = max(0.0, max(peaks)) if peaks else 0.0
    return float(per.max()), per


# -- saturation ---------------------------------------------------------------------------------------
def saturation(motion, limits_deg, *, fps: float | None = None, tol_deg: float = 1.0) -> float:
    """Share of frames with any axis within ``tol_deg`` of its limit.

    ``limits_deg``: ``(D, 2)`` lower/upper limits in degrees (None entries or ±inf for no limit)."""
    a, _ = _deg(motion, fps if fps is not None else 1.0)
    lim = np.asarray(limits_deg, dtype=float)
    if lim.shape != (a.shape[1], 2):
        raise ParameterError(f"limits_deg must have shape ({a.shape[1]}, 2); got {lim.shape}")
    near = (a <= lim[:, 0] + tol_deg) | (a >= lim[:, 1] - tol_deg)
    return float(np.mean(near.any(axis=1)))


# -- pauses -------------------------------------------------------------------------------------------
def speech_mask_for(audio, motion) -> np.ndarray:
    """The package's VAD (:func:`headmotion.features.vad.speaking_mask`) at the motion's frames."""
    from ...features.vad import speaking_mask

    return speaking_mask(audio, fps=float(motion.fps), n_frames=len(motion))


def pause_speed_ratio(motion, speech_mask, *, fps: float | None = None, min_pause_s: float = 0.5) -> float:
    """Mean speed in pauses (non-speech ≥ ``min_pause_s``) over mean speed in speech (nan when
    either is empty)."""
    a, f = _deg(motion, fps)
    mask = np.asarray(speech_mask, bool)
    if len(mask) < len(a):
        raise ParameterError(f"speech mask has {len(mask)} frames, the motion {len(a)}")
    return _pooled_pause_ratio_deg([a], mask, fps=f, min_pause_s=min_pause_s)


def pause_speed_ratio_k(samples: Sequence, speech_mask, *, fps: float, min_pause_s: float = 0.5) -> float:
    """:func:`pause_speed_ratio` of a stochastic system over its K samples for the same speech:
    pause and speech speeds pooled over the samples (as ``speed_hellinger_pooled_k`` pools the
    speed histogram).  One draw of a short recording carries its own sampling
    noise: le2012 on a 12-s ZEGGS fold gives 0.37 / 0.50 / 0.38 / 0.77 for seeds 0–3."""
    return _pooled_pause_ratio_deg([_deg(np.asarray(s, dtype=np.float64), fps)[0] for s in samples],
                                   np.asarray(speech_mask, bool), fps=fps, min_pause_s=min_pause_s)


def _pooled_pause_ratio_deg(angles, mask: np.ndarray, *, fps: float, min_pause_s: float) -> float:
    """The pause/speech speed ratio pooled over motions in degrees that share the speech ``mask``
    (a frame more or less at the end: the shorter); a frame-to-frame speed belongs to a stretch
    when both its frames do."""
    pairs = []
    for a in angles:
        n = min(len(a), len(mask))
        pairs.append(pause_speech_speeds(a[:n], mask[:n], fps=fps, min_pause_s=min_pause_s))
    return pooled_pause_ratio(pairs)


# -- diversity ----------------------------------------------------------------------------------------
def diversity(samples: Sequence, reference) -> float:
    """Mean pairwise per-frame distance of K ≥ 2 samples over the reference's total SD."""
    if len(samples) < 2:
        raise ParameterError(f"diversity needs at least 2 samples; got {len(samples)}")
    arrs = [M.as_array(s, name="sample")[0] for s in samples]
    n = min(len(a) for a in arrs)
    ref = M.as_array(reference, name="reference")[0]
    tot = float(np.sqrt(ref.var(axis=0).sum()))
    if tot <= 0:
        return float("nan")
    d = [np.linalg.norm(arrs[i][:n] - arrs[j][:n], axis=1).mean()
         for i in range(len(arrs)) for j in range(i + 1, len(arrs))]
    return float(np.mean(d) / tot)


# -- beat consistency ---------------------------------------------------------------------------------
def speech_onsets(audio) -> np.ndarray:
    """Speech onset times (s) by ``librosa.onset.onset_detect`` (spectral flux, default peak
    picking); librosa's compiled functions are first used under :mod:`headmotion.numba_cache`'s lock."""
    from ...numba_cache import first_use, import_librosa

    librosa = import_librosa()
    y = np.asarray(audio.samples, dtype=np.float32)
    if y.ndim > 1:
        y = y.mean(axis=1)
    with first_use("librosa.onset.onset_detect"):
        return librosa.onset.onset_detect(y=y, sr=int(audio.sample_rate), units="time")


def motion_beats(motion, *, fps: float | None = None, order_s: float = 7 / 30) -> np.ndarray:
    """Times (s) of the local minima of the speed (central differences; extremum order ``order_s``
    seconds)."""
    from scipy.signal import argrelextrema

    a, f = _deg(motion, fps)
    sp = np.linalg.norm(np.gradient(a, axis=0), axis=1) * f  # central differences: speed at each frame
    order = max(1, int(round(order_s * f)))
    idx = argrelextrema(sp, np.less, order=order)[0]
    return idx / f


def beat_consistency(motion_beat_times, onset_times, *, sigma: float = 0.3) -> float:
    """BC: mean over onsets of ``exp(−d²/2σ²)``, ``d`` the distance to the nearest motion beat."""
    mb = np.asarray(motion_beat_times, float)
    on = np.asarray(onset_times, float)
    if len(on) == 0:
        return float("nan")
    if len(mb) == 0:
        return 0.0
    d = np.min(np.abs(on[:, None] - mb[None, :]), axis=1)
    return float(np.mean(np.exp(-d ** 2 / (2 * sigma ** 2))))


# -- coupling -----------------------------------------------------------------------------------------
def coupling(reference, features, candidate, *, window_s: float = 3.0, n_shifts: int = 200, seed=0) -> dict:
    """FCCA (whole recording) and local CCA (``window_s`` windows) of the candidate with the
    speech features, each with its circular-shift null; a flat dict."""
    from . import chance as C

    ref = reference.rotvec if isinstance(reference, Motion) else reference
    fps = float(reference.fps) if isinstance(reference, Motion) else None
    fr = C.fcca_null(ref, features, candidate, n_shifts=n_shifts, seed=seed)
    cand, _ = M.as_array(candidate, name="candidate")
    feat, ff = M.as_array(features, name="features")
    n = min(len(cand), len(feat))
    f = fps or ff
    w = int(round(window_s * f)) if f else M.DEFAULT_WINDOW
    w = max(10, min(w, n))
    lr = C.local_cca_null(cand[:n], feat[:n], window=w, n_shifts=n_shifts, seed=seed)
    return {"fcca": fr.score, **fr.as_dict("fcca_"), "lcca": lr.score, **lr.as_dict("lcca_")}


def stouffer(p_values, *, n_shifts: int | None = None) -> float:
    """One-sided combined p-value of independent tests (Stouffer's Z).

    With ``n_shifts``, the p-values are circular-shift p-values ``(1 + k) / (n_shifts + 1)``
    (:mod:`headmotion.evaluation.measures.chance`; ``k`` shifts scored at least as high) and each is
    replaced by its mid-p ``(k + 0.5) / (n_shifts + 1)`` before the normal quantile: a discrete
    p-value of 1 (every shift scored higher) then counts as z = −Φ⁻¹(1 − 0.5/(n + 1)), the mirror
    of the best possible recording, instead of the −7 that clipping at 1 − 1e-12 gave it (one
    such recording outweighed three perfectly coupled ones; mid-p values are uniform-centred
    under the null, Lancaster 1961).  Without it, continuous p-values clipped to (1e-12, 1 − 1e-12)."""
    from scipy.stats import norm

    p = np.asarray([x for x in p_values if np.isfinite(x)], float)
    if len(p) == 0:
        return float("nan")
    if n_shifts is not None:
        p = np.clip(p - 0.5 / (int(n_shifts) + 1), 0.5 / (int(n_shifts) + 1), 1 - 0.5 / (int(n_shifts) + 1))
    p = np.clip(p, 1e-12, 1 - 1e-12)
    z = norm.isf(p).sum() / np.sqrt(len(p))
    return float(norm.sf(z))


def pooled_coupling(rows: Sequence[Mapping], *, n_shifts: int | None = None) -> dict:
    """Mean FCCA/local-CCA excess over recordings and the Stouffer-combined p-values (mid-p of
    the circular-shift p-values when ``n_shifts`` is given, see :func:`stouffer`)."""
    out = {}
    for k in ("fcca", "lcca"):
        ex = [r[f"{k}_excess"] for r in rows if f"{k}_excess" in r]
        ps = [r[f"{k}_p"] for r in rows if f"{k}_p" in r]
        out[f"{k}_excess"] = float(np.mean(ex)) if ex else float("nan")
        out[f"{k}_p_pooled"] = stouffer(ps, n_shifts=n_shifts)
    return out


# -- everything on one pair ---------------------------------------------------------------------------
def realism(reference, candidate, *, fps: float | None = None, speech_mask=None, onsets=None, features=None,
            limits_deg=None, samples=None, n_shifts: int = 200, seed=0) -> dict:
    """All measures on one (reference, candidate) pair → one flat dict (a metrics.csv row's
    columns).  Measures whose context is not given (mask, onsets, features, limits, samples) are
    nan.  Both motions must have the same rate (a bare-array candidate takes the reference's); lengths
    are trimmed to the shorter."""
    r, f = _deg(reference, fps)
    c, fc = _deg(candidate, fps if fps is not None or isinstance(candidate, Motion) else f)
    if abs(f - fc) > 1e-6:
        raise ParameterError(f"reference is at {f:g} fps but candidate at {fc:g} fps; resample one first")
    n = min(len(r), len(c))
    R, Cm = r[:n] / DEG, c[:n] / DEG
    row: dict = {"n_frames": n, "seconds": n / f}
    sr, sc = band_shares(R, fps=f), band_shares(Cm, fps=f)
    for name, a, b in zip(BAND_NAMES, sr, sc):
        row[f"band_{name}"] = float(b)
        row[f"band_{name}_ref"] = float(a)
    row["spectral_l1"] = spectral_distance(sr, sc)
    sdr = sd_ratio(R, Cm)
    sdc = (Cm * DEG).std(axis=0)
    for j, ax in enumerate(AXES):
        row[f"sd_{ax}"] = float(sdc[j])
        row[f"sd_ratio_{ax}"] = float(sdr[j])
    row["drift"] = float(np.mean(drift(Cm, fps=f)))
    row["drift_ref"] = float(np.mean(drift(R, fps=f)))
    sp_r, sp_c = speed(R, fps=f), speed(Cm, fps=f)
    row["speed_mean"] = float(sp_c.mean())
    row["speed_hellinger"] = hellinger_values(sp_r, sp_c)
    row["accel_hellinger"] = hellinger_values(acceleration(R, fps=f), acceleration(Cm, fps=f))
    lc, lc_axes = limit_cycle_index(Cm, fps=f)
    row["limit_cycle"] = lc
    row["limit_cycle_ref"] = limit_cycle_index(R, fps=f)[0]
    row["saturation"] = saturation(Cm, limits_deg, fps=f) if limits_deg is not None else float("nan")
    if speech_mask is not None:
        mask = np.asarray(speech_mask, bool)[:n]
        row["pause_ratio"] = pause_speed_ratio(Cm, mask, fps=f)
        row["pause_ratio_ref"] = pause_speed_ratio(R, mask, fps=f)
        row["pause_ratio_k"] = (pause_speed_ratio_k(samples, mask, fps=f)
                                if samples is not None and len(samples) >= 2 else float("nan"))
    else:
        row["pause_ratio"] = row["pause_ratio_ref"] = row["pause_ratio_k"] = float("nan")
    row["diversity"] = diversity(samples, R) if samples is not None and len(samples) >= 2 else float("nan")
    if onsets is not None:
        row["bc"] = beat_consistency(motion_beats(Cm, fps=f), onsets)
        row["bc_ref"] = beat_consistency(motion_beats(R, fps=f), onsets)
    else:
        row["bc"] = row["bc_ref"] = float("nan")
    if features is not None:
        feat = M.as_array(features, name="features")[0]
        m = min(n, len(feat))
        row.update(coupling(R[:m], feat[:m], Cm[:m], window_s=3.0, n_shifts=n_shifts, seed=seed)
                   if m >= 20 else {})
    return row


SUMMARY_KEYS = ("band_1.5_4", "band_1.5_4_ref", "spectral_l1", "sd_ratio_pitch", "sd_ratio_yaw", "sd_ratio_roll",
                "speed_hellinger", "accel_hellinger", "limit_cycle", "limit_cycle_ref", "saturation", "pause_ratio",
                "pause_ratio_ref", "pause_ratio_k", "diversity", "bc", "bc_ref", "drift", "drift_ref", "fcca", "lcca")


def realism_rows(conditions: Mapping[str, Sequence], references: Sequence, *, recording_ids: Sequence[str] | None = None,
                 speech_masks: Sequence | None = None, onsets: Sequence | None = None,
                 features: Sequence | None = None, limits_deg: Mapping[str, np.ndarray] | None = None,
                 samples: Mapping[str, Sequence[Sequence]] | None = None, n_shifts: int = 200,
                 seed=0) -> list[dict]:
    """Rows for metrics.csv: one per (condition, recording) and one ``recording="ALL"`` per
    condition (median of each measure over recordings, except ``fcca_excess``/``lcca_excess``: the
    mean, with ``fcca_p_pooled``/``lcca_p_pooled`` combined by Stouffer).

    Parameters
    ----------
    conditions : ``{name: [candidate motion per recording]}`` (same order as ``references``)
    references : ground-truth motion per recording
    recording_ids : names of the recordings (default ``rec0``, ``rec1``, …)
    speech_masks, onsets, features : per recording, optional (see :func:`realism`)
    limits_deg : ``{condition: (3, 2) limits}``, optional
    samples : ``{condition: [[K samples] per recording]}``, optional (diversity)
    """
    ids = list(recording_ids) if recording_ids is not None else [f"rec{i}" for i in range(len(references))]
    out: list[dict] = []
    for name, cands in conditions.items():
        if len(cands) != len(references):
            raise ParameterError(f"condition {name!r} has {len(cands)} motions for {len(references)} recordings")
        rows = []
        for i, (ref, cand) in enumerate(zip(references, cands)):
            row = realism(ref, cand, speech_mask=None if speech_masks is None else speech_masks[i],
                          onsets=None if onsets is None else onsets[i],
                          features=None if features is None else features[i],
                          limits_deg=None if limits_deg is None else limits_deg.get(name),
                          samples=None if samples is None or name not in samples else samples[name][i],
                          n_shifts=n_shifts, seed=seed)
            rows.append({"condition": name, "recording": ids[i], **row})
        out.extend(rows)
        summ: dict = {"condition": name, "recording": "ALL"}
        keys = [k for k in rows[0] if k not in ("condition", "recording")]
        for k in keys:
            vals = np.array([r.get(k, np.nan) for r in rows], float)
            summ[k] = float(np.nanmedian(vals)) if np.isfinite(vals).any() else float("nan")
        summ["spectral_l1_pooled"] = mean_shares_distance(
            *[[[r[f"band_{b}{x}"] for b in BAND_NAMES] for r in rows] for x in ("_ref", "")])
        if features is not None:
            summ.update(pooled_coupling(rows, n_shifts=n_shifts))
        out.append(summ)
    return out


def long_rows(rows: Sequence[Mapping], *, prefix: str = "realism_") -> list[dict]:
    """Wide rows of :func:`realism_rows` → the long ``{system, recording, metric, value}`` rows of
    ``evaluate``'s metrics.csv (metric names prefixed, nan kept)."""
    out = []
    for r in rows:
        for k, v in r.items():
            if k in ("condition", "recording", "set"):
                continue
            try:
                val = float(v)
            except (TypeError, ValueError):
                continue
            out.append({"system": r["condition"], "recording": r["recording"], "metric": prefix + k, "value": val})
    return out


__all__ = [
    "long_rows", "BANDS", "BAND_NAMES", "psd", "band_shares", "spectral_distance", "pooled_spectral_distance", "mean_shares_distance", "sd_ratio", "drift", "speed", "acceleration",
    "histogram_edges", "histogram", "hellinger", "hellinger_values", "autocorrelation", "limit_cycle_index",
    "saturation", "speech_mask_for", "pause_mask", "pause_speed_ratio", "pause_speed_ratio_k", "diversity", "speech_onsets",
    "motion_beats", "beat_consistency", "coupling", "stouffer", "pooled_coupling", "realism", "realism_rows",
    "SUMMARY_KEYS",
]
