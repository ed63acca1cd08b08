"""Speech activity per frame (paper §4.2: models are trained only on frames where the target
speaker speaks; evaluation uses all frames).

:func:`speaking_mask` is an energy + voicing detector with hangover smoothing:

1. frame energy in dB (25 ms Hamming window centred on each frame);
2. an adaptive threshold between the noise floor (10th percentile) and the speech level (95th
   percentile): ``floor + max(min_snr_db, 0.25 · (level − floor))``, which needs no
   training; if the clip's dynamic range is below ``min_snr_db`` it is all speech or all
   silence depending on its level (``silence_db``);
3. hangover smoothing: pauses shorter than ``max_gap_s`` (default 0.3 s, the inside of an
   utterance) are filled, regions shorter than ``min_speech_s`` (0.1 s) dropped, and the result
   extended by ``hangover_s`` (0.05 s) on both sides;
4. with ``use_voicing`` (default), a region must contain at least one voiced frame (Praat) to count
   as speech, which rejects breaths, clicks and broadband noise bursts.

:func:`load_speaking_annotation` overrides it with a user's annotation: a per-frame 0/1 column
(``.npy``, ``.csv``, ``.txt``) or an interval file (``start end [label]`` per line, seconds, tab- or
space-separated — Audacity's label export).  Intervals label speech unless their label is one of
``sil, silence, pause, noise, nonspeech, non-speech, 0``.

Libraries considered: webrtcvad (GMM VAD, 8–48 kHz only, unmaintained wheel), silero-vad (a torch
model download), pyannote (a gated model): none is needed for a single close-talk speaker, where
energy and voicing separate speech from pauses well.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import FormatError, LengthMismatchError, ParameterError
from ..types import Audio
from .frames import frame_signal, log_energy_db

#: the energy rule, shared with the causal detector (:mod:`.speech_activity`): the noise floor and
#: the speech level are these percentiles of the frame energy (dB); a frame is speech above
#: ``floor + max(MIN_SNR_DB, LEVEL_SHARE · (level − floor))``, or — with less than ``MIN_SNR_DB`` of
#: range — above ``SILENCE_DB`` dBFS
ENERGY_PERCENTILES = (10, 95)
MIN_SNR_DB = 10.0
SILENCE_DB = -50.0
LEVEL_SHARE = 0.25
SILENCE_LABELS = frozenset({"sil", "silence", "pause", "noise", "nonspeech", "non-speech", "0"})


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` index pairs of the True runs of a bool array."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def speaking_mask(audio: Audio, *, fps: float, n_frames: int | None = None, min_snr_db: float = MIN_SNR_DB,
                  silence_db: float = SILENCE_DB, max_gap_s: float = 0.3, min_speech_s: float = 0.1,
                  hangover_s: float = 0.05, use_voicing: bool = True, window_s: float = 0.025) -> np.ndarray:
    """True for frames where someone speaks.

    Parameters
    ----------
    audio : Audio
    fps : float
    n_frames : int, optional, default :func:`headmotion.align.n_frames` of the audio
    min_snr_db : float, smallest threshold above the noise floor (dB)
    silence_db : float, dBFS below which a clip without dynamics is all silence
    max_gap_s, min_speech_s, hangover_s : float, seconds (see module docstring)
    use_voicing : bool, require a voiced frame in each speech region
    window_s : float, energy window (s)

    Returns
    -------
    np.ndarray [shape=(n_frames,), dtype=bool]
    """
    from ..align import n_frames as count_frames

    if fps <= 0:
        raise ParameterError(f"fps must be positive; got {fps}")
    if n_frames is None:
        n_frames = count_frames(len(audio), audio.sample_rate, fps)
    if n_frames == 0:
        return np.zeros(0, dtype=bool)
    win = max(1, int(round(window_s * audio.sample_rate)))
    frames = frame_signal(audio.samples, sample_rate=audio.sample_rate, fps=fps, n_frames=n_frames,
                          win_length=win)
    e = log_energy_db(frames, np.hamming(win))
    floor, level = np.percentile(e, ENERGY_PERCENTILES[0]), np.percentile(e, ENERGY_PERCENTILES[1])
    if level - floor < min_snr_db:
        return np.full(n_frames, bool(np.median(e) > silence_db))
    thr = floor + max(min_snr_db, LEVEL_SHARE * (level - floor))
    mask = (e > thr) & (e > silence_db)

    # fill short pauses
    gap = int(round(max_gap_s * fps))
    for a, b in runs(~mask):
        if a > 0 and b < n_frames and b - a <= gap:
            mask[a:b] = True
    # drop blips
    shortest = int(round(min_speech_s * fps))
    for a, b in runs(mask):
        if b - a < shortest:
            mask[a:b] = False
    if use_voicing and mask.any():
        from .prosody import praat_pitch

        _, voiced = praat_pitch(audio, fps=fps, n_frames=n_frames)
        for a, b in runs(mask):
            if not voiced[a:b].any():
                mask[a:b] = False
    # hangover on both sides
    h = int(round(hangover_s * fps))
    if h > 0 and mask.any():
        mask = np.convolve(mask.astype(np.int32), np.ones(2 * h + 1, np.int32), mode="same") > 0
    return mask


def _fit_mask(mask: np.ndarray, n_frames: int, fps: float, path: Path, tolerance_s: float) -> np.ndarray:
    T = len(mask)
    if abs(T - n_frames) / fps > 1.0 / fps + tolerance_s:
        raise LengthMismatchError(
            f"{path}: annotation has {T} frames but {n_frames} are expected at {fps:g} fps "
            f"(difference {abs(T - n_frames) / fps:.3f} s > tolerance)"
        )
    if T >= n_frames:
        return mask[:n_frames]
    return np.concatenate([mask, np.repeat(mask[-1:] if T else [False], n_frames - T)])


def _parse_flag(cell: str, path: Path, line: int) -> bool:
    try:
        v = float(cell)
    except ValueError:
        raise FormatError(f"expected 0 or 1, found {cell!r}", path=path, line=line) from None
    if v not in (0.0, 1.0):
        raise FormatError(f"expected 0 or 1, found {cell!r}", path=path, line=line)
    return v == 1.0


def load_speaking_annotation(path, *, fps: float, n_frames: int, tolerance_s: float = 0.05) -> np.ndarray:
    """Read a user's speaking annotation as a per-frame mask.

    Parameters
    ----------
    path : str or Path
        ``.npy`` per-frame 0/1 (or bool) at ``fps``; a text file with one 0/1 per line (an optional
        header line is skipped); or an interval file with ``start end [label]`` per line in seconds.
    fps : float, frame rate of the result
    n_frames : int, length of the result
    tolerance_s : float, per-frame files may differ from ``n_frames`` by one frame plus this

    Returns
    -------
    np.ndarray [shape=(n_frames,), dtype=bool]
        For intervals, frame ``t`` is speaking when its centre ``(t + 0.5) / fps`` lies in a
        speech interval.
    """
    path = Path(path)
    if not path.is_file():
        raise FormatError("speaking annotation not found", path=path)
    if fps <= 0 or n_frames < 0:
        raise ParameterError(f"need fps > 0 and n_frames >= 0; got {fps}, {n_frames}")
    if path.suffix.lower() == ".npy":
        try:
            arr = np.load(path, allow_pickle=False)
        except ValueError as exc:
            raise FormatError(f"not a readable .npy file ({exc})", path=path) from None
        arr = np.asarray(arr).reshape(-1)
        if not np.all(np.isin(arr.astype(np.float64), (0.0, 1.0))):
            raise FormatError("per-frame annotation must hold only 0 and 1", path=path)
        return _fit_mask(arr.astype(bool), n_frames, fps, path, tolerance_s)

    text = path.read_text(encoding="utf-8-sig")
    rows = []
    for i, ln in enumerate(text.splitlines(), 1):
        s = ln.strip()
        if not s or s.startswith("#") or s.startswith("\\"):  # Audacity spectral-label lines start with "\"
            continue
        cells = [c.strip() for c in (s.split("\t") if "\t" in s else s.replace(",", " ").split())]
        rows.append((i, cells))
    if not rows:
        raise FormatError("empty annotation; expected per-frame 0/1 values or 'start end [label]' lines",
                          path=path)
    # header line (non-numeric first cell) is skipped
    def numeric(c):
        try:
            float(c)
            return True
        except ValueError:
            return False

    if not numeric(rows[0][1][0]):
        rows = rows[1:]
    if not rows:
        raise FormatError("annotation has a header but no rows", path=path)
    widths = {len(c) for _, c in rows}
    if widths == {1}:
        mask = np.array([_parse_flag(c[0], path, i) for i, c in rows], dtype=bool)
        return _fit_mask(mask, n_frames, fps, path, tolerance_s)
    centres = (np.arange(n_frames) + 0.5) / fps
    mask = np.zeros(n_frames, dtype=bool)
    for i, cells in rows:
        if len(cells) < 2:
            raise FormatError(f"expected 'start end [label]', found {' '.join(cells)!r}", path=path, line=i)
        try:
            start, end = float(cells[0]), float(cells[1])
        except ValueError:
            raise FormatError(f"start and end must be seconds; found {cells[:2]!r}", path=path, line=i) from None
        if not (np.isfinite(start) and np.isfinite(end)) or end < start or start < 0:
            raise FormatError(f"interval {start}–{end} s is not valid (need 0 <= start <= end)",
                              path=path, line=i)
        label = " ".join(cells[2:]).strip().lower()
        if label in SILENCE_LABELS:
            continue
        mask |= (centres >= start) & (centres < end)
    return mask


__all__ = ["speaking_mask", "load_speaking_annotation", "SILENCE_LABELS"]
