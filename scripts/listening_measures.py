"""What a listening head does in conversations built from real speech (docs/listening.md).

No recorded listener is reachable here, so the measures are of the head itself.  Each conversation
is two voices taking turns: this head's side (voice A, turns cut from one recording at its pauses)
and the other's (voice B, likewise), 0.4–0.9 s between turns, both sides on one timeline.  The
shipped streaming model synthesises A's side hearing B's (``synthesize(A, hear=B)``, seeds 0–3):

* **nods per minute of heard speech** (B's turns; their voiced time beside it);
* **nods that follow a cue**: the share of nods starting 0.2–1.2 s after the start of a region of
  low pitch (below B's 26th percentile for ≥ 110 ms: P1–P2 of Ward & Tsukahara without their
  other conditions), against the same share for the nods circularly shifted within B's turns
  (1000 random shifts): ``p`` = the share of shifts that follow cues as often or more;
* **the listening head's speed** (°/s, 6 Hz low-pass at 25 fps, the waiting measure's footing) in
  B's turns, beside the model's waiting head there (``listening=0``) and the speed of the
  recorded pauses of the talking-video corpus (:func:`pause_segment_speeds`).

    python scripts/listening_measures.py [--corpus ~/.cache/headmotion/corpus/talking_video] \
        [--save .scratch/listen]        # also writes conversation_*.wav (A, B, mixed) there
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared" / "data" / "speech"
SR = 16000
#: (this head's voice, the other's voice): two different speakers each
PAIRS = [(ROOT / "examples/speech/speech_female.wav", SHARED / "2_scott_0_103_103_28s.wav"),
         (ROOT / "examples/speech/speech_male.wav", SHARED / "audio3_20sec.wav"),
         (SHARED / "00083.wav", SHARED / "jfk.flac")]


def turns(x: np.ndarray, *, target_s: float = 4.0) -> list[np.ndarray]:
    """``x`` cut into turns of about ``target_s`` at its quietest 50 ms near each cut."""
    hop = SR // 20
    e = np.array([np.mean(x[i:i + hop] ** 2) for i in range(0, len(x) - hop, hop)])
    cuts, at = [0], 0
    while at + int(1.5 * target_s * SR) < len(x):
        lo, hi = (at + int(0.75 * target_s * SR)) // hop, (at + int(1.25 * target_s * SR)) // hop
        at = (lo + int(np.argmin(e[lo:hi]))) * hop
        cuts.append(at)
    cuts.append(len(x))
    return [x[a:b] for a, b in zip(cuts[:-1], cuts[1:]) if b - a > SR // 2]


def conversation(a_path, b_path, seed: int = 0):
    """(own, heard, B's turns as (start, end) seconds): A and B alternating, A first."""
    from headmotion.io import load_audio

    rng = np.random.default_rng(seed)
    ta = turns(load_audio(a_path, sample_rate=SR).samples)
    tb = turns(load_audio(b_path, sample_rate=SR).samples)
    own, heard, spans, t = [], [], [], 0
    for k in range(max(len(ta), len(tb))):
        for who, tt in (("a", ta), ("b", tb)):
            if k >= len(tt):
                continue
            x, z = tt[k], np.zeros(len(tt[k]), np.float32)
            own.append(x if who == "a" else z)
            heard.append(z if who == "a" else x)
            if who == "b":
                spans.append((t / SR, (t + len(x)) / SR))
            gap = np.zeros(int(rng.uniform(0.4, 0.9) * SR), np.float32)
            own.append(gap)
            heard.append(gap)
            t += len(x) + len(gap)
    return np.concatenate(own), np.concatenate(heard), spans


def heard_pitch(heard: np.ndarray):
    """(log F0, voiced) of the heard side at 100 frames/s, as the listening layer tracks it."""
    from headmotion.features.streaming import StreamingF0e

    ex = StreamingF0e(sample_rate=SR, fps=100.0, smooth_frames=1, smooth_lookahead=0, delta_lookahead=0,
                      voicing=True)
    rows = np.vstack([ex.push(heard), ex.flush()])
    return rows[:, 0], rows[:, -1] > 0.5


def low_regions(lf, voiced) -> np.ndarray:
    """Start times (s) of regions below the speaker's 26th percentile pitch for ≥ 110 ms (P1–P2)."""
    thr = np.percentile(lf[voiced], 26)
    low = voiced & (lf < thr)
    starts, run = [], 0
    for i, v in enumerate(low):
        run = run + 1 if v else 0
        if run == 11:
            starts.append((i - 10) / 100.0)
    return np.array(starts)


def follow_share(nods, cues) -> float:
    if not len(nods):
        return float("nan")
    return float(np.mean([np.any((n - cues >= 0.2) & (n - cues <= 1.2)) for n in nods]))


def shifted_p(nods, cues, spans, rng, n: int = 1000) -> tuple[float, float]:
    """(p, the shifted nods' mean share): p is the share of circular shifts of the nods (within B's turns joined end to end) that follow
    the cues as often as the nods do or more."""
    obs = follow_share(nods, cues)
    lens = np.array([b - a for a, b in spans])
    offs = np.concatenate([[0], np.cumsum(lens)])

    def to_joined(t):
        k = max(0, np.searchsorted([a for a, _ in spans], t, side="right") - 1)
        return offs[k] + min(t - spans[k][0], lens[k])

    def from_joined(u):
        k = min(len(spans) - 1, np.searchsorted(offs, u, side="right") - 1)
        return spans[k][0] + (u - offs[k])

    total = offs[-1]
    jn = np.array([to_joined(t) for t in nods])
    hits, shares = 0, []
    for _ in range(n):
        s = rng.uniform(0, total)
        shares.append(follow_share(np.array([from_joined((u + s) % total) for u in jn]), cues))
        hits += shares[-1] >= obs
    return (hits + 1) / (n + 1), float(np.nanmean(shares))


def speed_in(motion, spans) -> float:
    from headmotion.evaluation.detection.detectability import FPS, prepare

    x = prepare(motion)
    v = np.linalg.norm(np.diff(x, axis=0), axis=1) * FPS
    keep = np.zeros(len(v), bool)
    for a, b in spans:
        keep[int(a * FPS) + int(0.7 * FPS):int(b * FPS)] = True  # past the easing
    return float(v[keep[:len(v)]].mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", type=Path, default=Path.home() / ".cache/headmotion/corpus/talking_video")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--save", type=Path, default=None)
    args = ap.parse_args()
    from headmotion.synthesis import load_model, synthesize
    from headmotion.types import Audio

    model = load_model("stream")
    rng = np.random.default_rng(0)
    print("| conversation | heard speech (s) | nods/min of heard speech | follow a cue | shifted | p per seed | "
          "speed listening / waiting (°/s) |")
    print("|---|---|---|---|---|---|---|")
    all_nods, all_min, sp_l, sp_w = 0, 0.0, [], []
    for i, (a, b) in enumerate(PAIRS):
        if not (a.exists() and b.exists()):
            print(f"| {a.name} / {b.name} | missing | | | | | |")
            continue
        own, heard, spans = conversation(a, b, seed=i)
        if args.save is not None:
            import soundfile as sf

            args.save.mkdir(parents=True, exist_ok=True)
            for name, x in (("a", own), ("b", heard), ("mix", np.clip(own + heard, -1, 1))):
                sf.write(args.save / f"conversation_{i}_{name}.wav", x, SR)
        lf, vo = heard_pitch(heard)
        cues = low_regions(lf, vo)
        minutes = sum(b - a for a, b in spans) / 60.0
        nods, shares, ps, shifted = [], [], [], []
        for seed in range(args.seeds):
            m = synthesize(Audio(own, SR), model, seed=seed, hear=Audio(heard, SR))[0]
            w = synthesize(Audio(own, SR), model, seed=seed, hear=Audio(heard, SR), listening=0)[0]
            t = np.array(m.meta["nod_frames"]) / m.fps
            nods.append(len(t))
            shares.append(follow_share(t, cues))
            p_, sh = shifted_p(t, cues, spans, rng, n=1000)
            ps.append(p_)
            shifted.append(sh)
            sp_l.append(speed_in(m, spans))
            sp_w.append(speed_in(w, spans))
        all_nods += sum(nods)
        all_min += minutes * args.seeds
        print(f"| {a.name} hears {b.name} | {minutes * 60:.1f} ({vo.sum() / 100:.1f} voiced) | "
              f"{np.mean(nods) / minutes:.1f} | {np.nanmean(shares):.2f} | {np.nanmean(shifted):.2f} | "
              f"{' '.join(f'{v:.3f}' for v in ps)} | "
              f"{np.mean(sp_l[-args.seeds:]):.1f} / {np.mean(sp_w[-args.seeds:]):.1f} |")
    print(f"\nall: {all_nods / all_min:.1f} nods per minute of heard speech; listening head {np.mean(sp_l):.1f} °/s, "
          f"waiting head {np.mean(sp_w):.1f} °/s in the other's turns")
    if args.corpus.exists():
        from headmotion.corpus import Corpus
        from headmotion.evaluation.measures.waiting import pause_segment_speeds

        recs = [r for r in Corpus.load(args.corpus) if not r.id.startswith("mead_lrs3") and r.duration >= 4]
        p10, p50, p90 = pause_segment_speeds(recs).percentiles()
        print(f"recorded pauses (talking-video corpus): {p10:.1f}–{p90:.1f} °/s (10th–90th), median {p50:.1f}")
    else:
        print(f"no corpus at {args.corpus}: recorded pause speeds not measured")


if __name__ == "__main__":
    main()
