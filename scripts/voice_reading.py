#!/usr/bin/env python
"""What the frame-by-frame prosody reads on voices from each source, against Praat's whole-file
reading (docs/decisions/follow-any-voice.md).

Per source of the corpus (and for a folder of speech with no head, ``--speech``), pooled over its
recordings at 25 fps:

* **voiced**: the share of frames Praat calls voiced, and YIN (``StreamingF0e``) at the aperiodicity
  limits 0.35 and 0.45;
* **speech hops called pauses**: of the 15-frame hops Praat calls speech (a voiced share ≥ 0.2,
  motion-match's test), the share YIN's voicing calls a pause — where the head holds still;
* **lag**: the shift (ms) that best aligns each causal f0e-live column (smoothing and deltas ending at
  their frame) with the centred one (``motion-match[centred=true]``): energy, Δenergy, Δlog F0;
* **level**: the spread over recordings of the speech's loud frames (90th percentile of energy, dB).

    python scripts/voice_reading.py ~/.cache/headmotion/corpus/talking_video --speech ../shared/data/speech
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np

FPS = 25.0
HOP = 15


def reading(audio) -> dict:
    from headmotion.align import n_frames
    from headmotion.features import extract
    from headmotion.features.prosody import praat_pitch
    from headmotion.systems.motion_match import CENTRED_FEATURES, LIVE_FEATURES

    n = n_frames(len(audio.samples), audio.sample_rate, FPS)
    _, praat = praat_pitch(audio, fps=FPS, n_frames=n)
    cols = ("energy", "d_energy", "d_logf0", "voiced")
    causal = {vt: extract("f0e-live", audio, fps=FPS, n_frames=n, voicing_threshold=vt, **LIVE_FEATURES).select(cols).values
              for vt in (0.35, 0.45)}
    centred = extract("f0e-live", audio, fps=FPS, n_frames=n, **{**LIVE_FEATURES, **CENTRED_FEATURES}).select(cols).values
    hops = [slice(t, t + HOP) for t in range(0, n - HOP + 1, HOP)]
    speech = np.array([praat[h].mean() >= 0.2 for h in hops], bool)
    out = {"praat": praat.astype(float), "speech_hops": speech}
    for vt, x in causal.items():
        out[f"yin{vt}"] = x[:, 3]
        out[f"pause{vt}"] = np.array([x[h, 3].mean() < 0.2 for h in hops], bool)
    out["pair"] = (causal[0.35][:, :3], centred[:, :3])
    out["level"] = float(np.percentile(causal[0.35][:, 0], 90))
    return out


def best_lag_ms(causal: np.ndarray, centred: np.ndarray, max_lag: int = 4) -> float:
    """The shift (ms, causal later than centred > 0) of the highest correlation."""
    best, lag = -2.0, 0
    for k in range(0, max_lag + 1):
        a, b = causal[k:], centred[:len(centred) - k]
        if len(a) > 10 and a.std() > 0 and b.std() > 0:
            r = np.corrcoef(a, b)[0, 1]
            if r > best:
                best, lag = r, k
    return 1000.0 * lag / FPS


def summarise(name: str, rows: list[dict]) -> str:
    cat = lambda k: np.concatenate([r[k] for r in rows])  # noqa: E731
    speech = cat("speech_hops")
    lags = []
    for j in range(3):
        c = np.concatenate([r["pair"][0][:, j] for r in rows])
        z = np.concatenate([r["pair"][1][:, j] for r in rows])
        lags.append(best_lag_ms(c, z))
    levels = [r["level"] for r in rows]
    return (f"| {name} | {len(rows)} | {cat('praat').mean():.2f} / {cat('yin0.35').mean():.2f} / "
            f"{cat('yin0.45').mean():.2f} | {cat('pause0.35')[speech].mean():.2f} / {cat('pause0.45')[speech].mean():.2f} | "
            f"{lags[0]:.0f} / {lags[1]:.0f} / {lags[2]:.0f} | {min(levels):.0f} … {max(levels):.0f} |")


def main(argv=None) -> int:
    from headmotion.corpus import Corpus
    from headmotion.evaluation.protocol.folds import source_of
    from headmotion.io import load_audio

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corpus", type=Path)
    ap.add_argument("--speech", type=Path, default=None, help="a folder of speech with no head")
    a = ap.parse_args(argv)
    groups: dict[str, list] = defaultdict(list)
    corpus = Corpus.load(a.corpus)
    for e, r in zip(corpus.entries, corpus):
        groups[source_of(e) or "?"].append(reading(r.audio))
    if a.speech is not None:
        for f in sorted(p for p in a.speech.iterdir() if p.suffix.lower() in (".wav", ".flac", ".mp3")):
            groups[f"{a.speech.name}/"].append(reading(load_audio(f, sample_rate=16000)))
    print("| source | recordings | voiced: Praat / YIN 0.35 / YIN 0.45 | speech hops called pauses: YIN 0.35 / 0.45 "
          "| causal lag (ms): energy / Δenergy / Δlog F0 | loud level (dB FS) |")
    print("|---|---|---|---|---|---|")
    for name, rows in groups.items():
        print(summarise(name, rows), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
