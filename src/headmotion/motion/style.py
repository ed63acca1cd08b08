"""Style from a reference: make a motion move like a given recording.

The seeds do not transfer style, but the thesis's corpus analysis finds head motion more speaker-
than task-dependent (§3.5.1: speakers lie further apart than tasks), which is why a user may want
a given speaker's way of moving rather than the model's average.  What is chosen here, and why:

**What "style" is.**  Three figures per axis (pitch, yaw, roll, in degrees, intrinsic yaw → pitch
→ roll as :func:`headmotion.rotations.rotvec_to_pitch_yaw_roll`):

* the **mean pose** (where the head rests: a speaker who looks down a little, turned aside),
* the **SD** about it (how much the head moves),
* the **spectral balance**: the shares of the motion's power in four bands, ``0–0.5 Hz`` (slow
  drift and posture changes), ``0.5–1.5 Hz`` (phrase-level turns), ``1.5–4 Hz`` (nods and beats
  on stressed syllables) and ``≥ 4 Hz`` (quick jerks up to the Nyquist rate — head motion holds
  almost nothing above 10 Hz, and the video corpus is low-passed at 8 Hz, so a separate
  ``4–10 Hz`` band would only isolate tracking noise).

**How it is moved.**  The candidate's angles (mean removed) are split into the four bands by
zero-phase filters applied in the frequency domain to the mirrored signal ``[x, x[::-1]]`` (a
DCT-style extension: no step at the FFT's wrap-around, no phase shift).  Each band's gain is 1
inside the band and falls to 0 across a smooth raised-cosine crossover half an octave wide (in
log-frequency) around each edge; the bands' gains sum to one at every frequency, so the bands add
up to the signal exactly, and ``mean(band_k · x)`` partitions the variance into non-negative band
powers (Parseval) — those are the shares.  (Not Butterworth filter banks: their
crossovers overlap so much that the 0.5–1.5 and 1.5–4 Hz bands could not be set independently.)
The motion is reshaped by a gain curve ``G(f) = Σ g_k · band_k(f)``, ``g`` found by a few
fixed-point steps so that the styled motion's band shares equal the target shares (absorbing the
crossovers); then one overall gain per axis sets the SD to the target (shares are invariant to
it), and the target mean is added.  Zero-phase filtering and pure gains change no
timing: every nod stays where the speech put it.  A gain is clipped to ``max_gain`` so a band the
candidate barely has is not blown up from numerical dust.  Like any zero-phase filter, the bank
has end effects: the mirror extension puts a kink at each end, which the slow bands smear over
the first and last few seconds (a band holding under ~1% of the power is measured a few tenths of
a percent too high on a 40-s clip).

``strength`` in [0, 1] interpolates the targets (geometric for SD and shares, linear for the mean),
0 giving the candidate back unchanged.  With ``match_mean=False`` the candidate keeps its own
mean pose (useful when the reference is a video filmed from the side: its mean pose is the
camera's angle, not the speaker's posture).

Alternatives considered: matching the reference's power spectrum bin by bin (a Wiener-style
spectral shaping) over-fits to the reference's length and noise; re-fitting the model's
parameters to the reference needs a trainable model per system; quantile mapping of the angles
changes shape but not tempo.  Libraries: numpy's FFT for the filters (scipy.signal's Butterworth
bank was the first try, above); no maintained package does head-motion style transfer.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError
from ..rotations import pitch_yaw_roll_to_rotvec, rotvec_to_pitch_yaw_roll
from ..types import Motion
from .bands import BAND_EDGES_HZ, band_names

#: Crossover frequencies (Hz) between the bands (:mod:`headmotion.motion.bands`).
BAND_EDGES = BAND_EDGES_HZ
#: Names of the bands, low to high.
BAND_NAMES = band_names()  # ("0_0.5", "0.5_1.5", "1.5_4", "4_up"): the realism measure's spelling
#: A reference must be at least this long (s) for its slowest band to mean anything.
MIN_REFERENCE_SECONDS = 2.0

#: Width (octaves) of each raised-cosine crossover.
TRANSITION_OCTAVES = 0.5
_EPS = 1e-12


@dataclass(frozen=True)
class StyleProfile:
    """How a motion moves: per-axis mean pose, SD and band shares.

    Attributes
    ----------
    mean : (3,) degrees, pitch, yaw, roll
    sd : (3,) degrees
    shares : (3, 4) fraction of each axis's power in each band of :data:`BAND_NAMES` (rows sum to 1)
    seconds : float, length of the motion measured
    source : str
    """

    mean: np.ndarray
    sd: np.ndarray
    shares: np.ndarray
    seconds: float = 0.0
    source: str = ""
    bands: tuple = field(default=BAND_NAMES)

    def as_dict(self) -> dict:
        return {"mean_deg": np.round(self.mean, 4).tolist(), "sd_deg": np.round(self.sd, 4).tolist(),
                "shares": {b: np.round(self.shares[:, k], 4).tolist() for k, b in enumerate(self.bands)},
                "seconds": round(float(self.seconds), 3), "source": self.source}


def _lowpass_response(freqs: np.ndarray, cutoff: float, width: float = TRANSITION_OCTAVES) -> np.ndarray:
    """Zero-phase low-pass gain: 1 below ``cutoff·2^(−width/2)``, 0 above ``cutoff·2^(width/2)``,
    a raised cosine in log-frequency between."""
    lo = np.log2(cutoff) - width / 2
    with np.errstate(divide="ignore"):
        u = (np.log2(np.maximum(freqs, 1e-12)) - lo) / width
    return np.where(u <= 0, 1.0, np.where(u >= 1, 0.0, 0.5 * (1 + np.cos(np.pi * np.clip(u, 0, 1)))))


def band_responses(n: int, fps: float, edges=BAND_EDGES) -> np.ndarray:
    """``(n_bands, n + 1)`` gains on the ``rfft`` frequencies of a ``2n``-sample mirrored signal;
    they are non-negative and sum to one at every frequency."""
    freqs = np.fft.rfftfreq(2 * n, d=1.0 / fps)
    lows = [_lowpass_response(freqs, f) for f in edges]
    resp = [lows[0]] + [lows[k] - lows[k - 1] for k in range(1, len(lows))] + [1.0 - lows[-1]]
    return np.stack(resp)


def _filter(x: np.ndarray, gain: np.ndarray) -> np.ndarray:
    """Apply zero-phase frequency gains ``gain (..., F)`` to ``x (T, C)`` via a mirrored FFT.

    ``gain`` is ``(F,)`` for all columns, or ``(C, F)`` per column.  The mirror extension
    ``[x, x[::-1]]`` is continuous when repeated, so the FFT's wrap-around adds no step."""
    n = len(x)
    ext = np.concatenate([x, x[::-1]], axis=0)
    spec = np.fft.rfft(ext, axis=0)                    # (F, C)
    g = gain.T if gain.ndim == 2 else gain[:, None]
    return np.fft.irfft(spec * g, n=2 * n, axis=0)[:n]


def band_split(x, fps: float, edges=BAND_EDGES) -> np.ndarray:
    """Split ``x (T, C)`` into ``len(edges) + 1`` zero-phase bands that sum to ``x`` exactly.

    Returns ``(n_bands, T, C)``; band 0 is below ``edges[0]``, the last band above ``edges[-1]``.
    For mean-free ``x``, ``mean(band_k * x)`` is the power in band k: non-negative, and the bands'
    powers add up to ``mean(x ** 2)``.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim == 1:
        x = x[:, None]
    if len(x) < 8:
        raise ParameterError(f"band_split needs at least 8 frames; got {len(x)}")
    resp = band_responses(len(x), fps, edges)
    return np.stack([_filter(x, r) for r in resp])


def _angles(motion: Motion) -> np.ndarray:
    """Pitch, yaw, roll in degrees, unwrapped in time (continuous through ±180°)."""
    a = rotvec_to_pitch_yaw_roll(np.asarray(motion.rotvec), degrees=True)
    return np.degrees(np.unwrap(np.radians(a), axis=0))


def _band_power(x_centred: np.ndarray, fps: float) -> np.ndarray:
    """``(3, n_bands)`` power of each band of each axis (they add up to the variance)."""
    b = band_split(x_centred, fps)
    return np.maximum(np.mean(b * x_centred[None], axis=1).T, 0.0)


def _shares(power: np.ndarray) -> np.ndarray:
    tot = power.sum(axis=1, keepdims=True)
    return np.where(tot > _EPS, power / np.maximum(tot, _EPS), 1.0 / power.shape[1])


def style_profile(motion: Motion) -> StyleProfile:
    """Mean pose, SD and band shares of ``motion`` (see the module docstring)."""
    if not isinstance(motion, Motion):
        raise ParameterError(f"style_profile needs a Motion; got {type(motion).__name__}")
    if len(motion) < 8:
        raise ParameterError(f"a motion of {len(motion)} frames is too short to measure its style")
    a = _angles(motion)
    mean = a.mean(axis=0)
    xc = a - mean
    return StyleProfile(mean=mean, sd=xc.std(axis=0), shares=_shares(_band_power(xc, motion.fps)),
                        seconds=motion.duration, source=str(motion.meta.get("source", "")))


def apply_style(candidate: Motion, reference, *, strength: float = 1.0, match_mean: bool = True,
                max_gain: float = 10.0, n_iter: int = 6) -> Motion:
    """``candidate`` made to move like ``reference``: its SD, band shares and (optionally) mean pose.

    Parameters
    ----------
    candidate : Motion, e.g. a system's output for the speech (its timing is kept)
    reference : Motion or StyleProfile, the motion whose style to take (any frame rate; a Motion
        must be at least :data:`MIN_REFERENCE_SECONDS` long)
    strength : float in [0, 1], 1 = the reference's figures, 0 = the candidate unchanged
    match_mean : bool, also move the mean pose to the reference's (default True)
    max_gain : float ≥ 1, largest gain applied to any band (and smallest is ``1 / max_gain``)
    n_iter : int, fixed-point steps matching the band shares

    Returns
    -------
    Motion at the candidate's frame rate and length; ``meta["style"]`` holds the target figures.
    """
    if not isinstance(candidate, Motion):
        raise ParameterError(f"apply_style needs a Motion candidate; got {type(candidate).__name__}")
    if isinstance(reference, Motion):
        if reference.duration < MIN_REFERENCE_SECONDS:
            raise ParameterError(f"style reference is {reference.duration:.2f} s long; at least "
                                 f"{MIN_REFERENCE_SECONDS:g} s are needed to measure its slow band")
        ref = style_profile(reference)
    elif isinstance(reference, StyleProfile):
        ref = reference
    else:
        raise ParameterError(f"style reference must be a Motion or StyleProfile; got {type(reference).__name__}")
    s = float(strength)
    if not 0.0 <= s <= 1.0:
        raise ParameterError(f"style strength must be in [0, 1]; got {strength!r}")
    if not max_gain >= 1.0:
        raise ParameterError(f"max_gain must be >= 1; got {max_gain!r}")
    if len(candidate) < 8:
        raise ParameterError(f"a candidate of {len(candidate)} frames is too short to restyle")
    fps = candidate.fps
    a = _angles(candidate)
    mean_c = a.mean(axis=0)
    xc = a - mean_c
    resp = band_responses(len(xc), fps)              # (B, F)
    p_c = _band_power(xc, fps)                       # (3, B)
    sh_c, sd_c = _shares(p_c), xc.std(axis=0)
    # targets: geometric interpolation of SD and shares, linear of the mean
    sd_t = np.where(sd_c > _EPS, sd_c ** (1 - s) * np.maximum(ref.sd, _EPS) ** s, 0.0)
    sh_t = _shares(np.maximum(sh_c, _EPS) ** (1 - s) * np.maximum(ref.shares, _EPS) ** s)
    mean_t = mean_c + s * (ref.mean - mean_c) if match_mean else mean_c
    # band gains (3, B): start from the power ratio, then correct for the crossovers
    g = np.clip(np.sqrt(sh_t / np.maximum(sh_c, _EPS)), 1.0 / max_gain, max_gain)
    for _ in range(n_iter):
        y = _filter(xc, g @ resp)
        sh_y = _shares(_band_power(y, fps))
        g = np.clip(g * np.sqrt(sh_t / np.maximum(sh_y, _EPS)), 1.0 / max_gain, max_gain)
    y = _filter(xc, g @ resp)
    sd_y = y.std(axis=0)
    y = y * np.where(sd_y > _EPS, sd_t / np.maximum(sd_y, _EPS), 0.0)
    out = y + mean_t
    rv = pitch_yaw_roll_to_rotvec(out[:, 0], out[:, 1], out[:, 2], degrees=True)
    meta = dict(candidate.meta)
    meta["style"] = {"reference": ref.source, "strength": s, "match_mean": bool(match_mean),
                     "target_mean_deg": np.round(mean_t, 4).tolist(), "target_sd_deg": np.round(sd_t, 4).tolist(),
                     "band_gains": {b: np.round(g[:, k], 4).tolist() for k, b in enumerate(BAND_NAMES)}}
    return candidate.replace(rotvec=rv, meta=meta)


__all__ = ["StyleProfile", "style_profile", "apply_style", "band_split", "BAND_EDGES", "BAND_NAMES"]
