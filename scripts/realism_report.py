"""Realism of recorded heads and of every system on real speech (issue 14: the "before" table).

Measures (headmotion.evaluation.realism) for
* the recorded heads: the talking-video corpus (video-derived pose) and the ZEGGS mocap take;
* anchors: desync (the recording's own motion circularly shifted by half its length) and still;
* the bundled default model on the corpus speech (seen in training) and on ../shared/data/speech
  (unseen; compared with the pooled corpus heads);
* tws-basic, tws-hier, le2012 and one DNN (mfcc-dnn) trained on real data:
  the video corpus without mead_lrs3 (non-commercial) split into 2 speaker-disjoint folds, and the
  ZEGGS take split at its longest pauses into 4 folds (train on 3, drive with the 4th's speech).

Predictions of the trained systems are cached under ``--cache`` (delete it to recompute).
Runtime: the full run trains 4 systems × 6 folds (about 10 min on 2 idle cores, 25 min on a busy
machine); a rerun with the cache takes ~3 min; ``--quick`` (systems on the ZEGGS folds only, the
default on 8 recordings, 50 shifts) takes ~2 min.  Usage::

    PYTHONPATH=src nice python scripts/realism_report.py [--systems tws-basic tws-hier le2012 mfcc-dnn]
        [--csv out.csv] [--figures docs/figures] [--quick]
"""

from __future__ import annotations

import argparse
import hashlib
import time
from pathlib import Path

import numpy as np

from headmotion.corpus import Corpus, Recording
from headmotion.evaluation import realism as R
from headmotion.features import FeatureConfig
from headmotion.io import load_motion
from headmotion.io.audio import load_audio
from headmotion.types import Motion

HOME = Path.home() / ".cache/headmotion"
SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"
ZEGGS = SHARED / "mocap_speech/zeggs/067_Speech_2_x_1_0"
SPEECH = SHARED / "speech"

COLS = [("band_1.5_4", "1.5-4Hz"), ("band_1.5_4_ref", "(gt)"), ("band_0_0.5", "<0.5Hz"), ("spectral_l1", "L1"),
        ("sd_pitch", "SDp"), ("sd_yaw", "SDy"), ("sd_roll", "SDr"), ("sd_ratio_mean", "SDratio"),
        ("speed_hellinger", "Hspeed"), ("limit_cycle", "LC"), ("limit_cycle_ref", "(gt)"),
        ("saturation", "sat"), ("pause_ratio", "pause"), ("pause_ratio_ref", "(gt)"), ("drift", "drift"),
        ("bc", "BC"), ("fcca_excess", "FCCAx"), ("fcca_p_pooled", "p"), ("diversity", "div")]


def log(*a):
    print(*a, flush=True)


def zeggs_folds(n_folds: int = 4) -> list[Recording]:
    """The ZEGGS take cut at the middle of its longest pauses into ``n_folds`` parts of similar
    length (each ≥ 10 s)."""
    from headmotion.features.vad import _runs

    m = load_motion(ZEGGS.with_suffix(".bvh"))
    a = load_audio(ZEGGS.with_suffix(".wav"))
    rec = Recording.aligned("zeggs", "zeggs", "mocap", a, m)
    mask = R.speech_mask_for(rec.audio, rec.motion)
    T, f = len(rec.motion), rec.motion.fps
    mids = np.array([(s + e) // 2 for s, e in _runs(~mask) if e - s >= int(0.3 * f) and s > 0 and e < T])
    cuts = [0]
    for k in range(1, n_folds):
        target = k * T / n_folds
        c = int(mids[np.argmin(np.abs(mids - target))])
        if c - cuts[-1] >= 10 * f:
            cuts.append(c)
    cuts.append(T)
    out = []
    for i, (s, e) in enumerate(zip(cuts[:-1], cuts[1:])):
        mo = rec.motion.slice_frames(s, e)
        au = rec.audio.slice_seconds(s / f, e / f)
        out.append(Recording.aligned(f"zeggs_f{i}", "zeggs", "mocap", au, mo))
    return out


def video_corpus(path: Path, *, exclude=("mead_lrs3",)) -> list[Recording]:
    c = Corpus.load(path)
    return [r for r in c if not any(r.id.startswith(x) for x in exclude)]


def speaker_folds(recs: list[Recording], n: int = 2) -> list[list[int]]:
    spk = sorted({r.speaker for r in recs})
    key = {s: int(hashlib.md5(s.encode()).hexdigest(), 16) % n for s in spk}
    return [[i for i, r in enumerate(recs) if key[r.speaker] == k] for k in range(n)]


def create_system(name: str):
    from headmotion.systems import create

    if name in ("tws-basic", "tws-hier"):
        return create(name, features="f0e", fps=100.0)
    if name == "le2012":
        return create(name)
    return create(name, max_epochs=15, ae_max_epochs=20)


def predict(model, audio, seed):
    return model.predict(audio, seed=seed)


def at_rate(m: Motion, fps: float, n: int) -> np.ndarray:
    x = m if abs(m.fps - fps) < 1e-9 else m.resample(fps)
    rv = np.asarray(x.rotvec)
    if len(rv) < n:
        rv = np.vstack([rv, np.repeat(rv[-1:], n - len(rv), 0)])
    return rv[:n]


def context(rec: Recording, cache: dict):
    """Speech mask, onsets, f0e features at the motion's rate (cached per recording)."""
    if rec.id not in cache:
        m = rec.motion
        feats = FeatureConfig("f0e", fps=float(m.fps)).extract(rec.audio, n_frames=len(m)).values
        cache[rec.id] = (R.speech_mask_for(rec.audio, m), R.speech_onsets(rec.audio), np.asarray(feats))
    return cache[rec.id]


def limits_of(train: list[Recording]) -> np.ndarray:
    allr = np.vstack([r.motion.rotvec for r in train]) * R.DEG
    lo, hi = allr.min(0), allr.max(0)
    span = hi - lo
    return np.stack([lo - 0.1 * span, hi + 0.1 * span], 1)


def rows_for(name, recs, motions, ctx, *, limits=None, samples=None, n_shifts=100):
    masks, ons, feats = zip(*[context(r, ctx) for r in recs])
    rows = R.realism_rows({name: motions}, [r.motion for r in recs], recording_ids=[r.id for r in recs],
                          speech_masks=masks, onsets=ons, features=feats,
                          limits_deg={name: limits} if limits is not None else None,
                          samples={name: samples} if samples is not None else None, n_shifts=n_shifts)
    for r in rows:
        r["sd_ratio_mean"] = float(np.nanmean([r.get(f"sd_ratio_{a}", np.nan) for a in R.AXES]))
    return rows


def cross_validate(system: str, recs: list[Recording], folds: list[list[int]], cache_dir: Path, tag: str,
                   n_samples: int = 1):
    """Predictions (per recording, K samples) of ``system`` trained on the other folds."""
    f = cache_dir / f"{tag}_{system}.npz"
    if f.exists():
        z = np.load(f)
        return {r.id: [z[f"{r.id}_s{k}"] for k in range(n_samples)] for r in recs}, None
    out = {}
    t = time.time()
    for k, test in enumerate(folds):
        train = [recs[i] for i in range(len(recs)) if i not in test]
        model = create_system(system).fit(Corpus(train))
        lim = getattr(model, "limits_", None)
        for i in test:
            r = recs[i]
            out[r.id] = [at_rate(predict(model, r.audio, s), r.motion.fps, len(r.motion)) for s in range(n_samples)]
        log(f"  {tag} {system} fold {k + 1}/{len(folds)} ({time.time() - t:.0f} s)"
            + (f" clip yaw [{np.degrees(lim.lo[1]):.1f}, {np.degrees(lim.hi[1]):.1f}]" if lim is not None else ""))
    cache_dir.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(f, **{f"{rid}_s{k}": v[k] for rid, v in out.items() for k in range(n_samples)})
    return out, None


def print_table(rows, title):
    log(f"\n## {title}")
    log("| condition | " + " | ".join(c[1] for c in COLS) + " |")
    log("|---" * (len(COLS) + 1) + "|")
    for r in rows:
        if r["recording"] != "ALL":
            continue
        cells = []
        for k, _ in COLS:
            v = r.get(k, float("nan"))
            cells.append("" if v is None or (isinstance(v, float) and np.isnan(v)) else
                         (f"{v:.3f}" if k.endswith("p_pooled") else f"{v:.2f}"))
        log(f"| {r['condition']} | " + " | ".join(cells) + " |")



def write_rows_csv(rows, path) -> None:
    """The table's rows as CSV (set, condition, recording first, then the measures by name)."""
    import csv

    keys = sorted({k for r in rows for k in r}, key=lambda k: (k not in ("set", "condition", "recording"), k))
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    log(f"wrote {path}")

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--corpus", default=str(HOME / "corpus/talking_video"))
    ap.add_argument("--systems", nargs="*", default=["tws-basic", "tws-hier", "le2012", "mfcc-dnn"])
    ap.add_argument("--cache", default=str(HOME / "realism_report"))
    ap.add_argument("--csv", default=None)
    ap.add_argument("--figures", default=None)
    ap.add_argument("--model", default=None, help="default model file (default: the bundled one)")
    ap.add_argument("--samples", type=int, default=4, help="samples per recording for the default's diversity")
    ap.add_argument("--shifts", type=int, default=100)
    ap.add_argument("--quick", action="store_true", help="ZEGGS folds only for the systems, 8 recordings for the default")
    a = ap.parse_args()
    if a.quick:
        a.shifts = min(a.shifts, 50)
        a.samples = min(a.samples, 2)
    cache_dir = Path(a.cache)
    ctx: dict = {}
    all_rows = []
    figs: dict = {}

    video = video_corpus(Path(a.corpus))
    video = [r for r in video if r.motion.duration >= 4.0]
    zeg = zeggs_folds(4)
    log(f"video corpus: {len(video)} recordings ≥ 4 s (without mead_lrs3), "
        f"{sum(r.duration for r in video):.0f} s; ZEGGS folds: {[round(r.duration, 1) for r in zeg]}")

    # -- references and anchors
    for tag, recs in (("video", video), ("zeggs", zeg)):
        gt = [r.motion for r in recs]
        desync = [np.roll(r.motion.rotvec, len(r.motion) // 2, axis=0) for r in recs]
        still = [np.tile(r.motion.rotvec.mean(0), (len(r.motion), 1)) + 1e-9 for r in recs]
        rows = []
        for name, ms in (("ground-truth", gt), ("desync", desync), ("still", still)):
            rows += rows_for(name, recs, ms, ctx, n_shifts=a.shifts)
        figs[tag] = {"ground-truth": gt, "desync": [Motion(d, r.motion.fps) for d, r in zip(desync, recs)]}
        all_rows += [{"set": tag, **r} for r in rows]
        print_table(rows, f"{tag}: recorded heads and anchors")

    # -- the default model
    from headmotion.systems.base import load_model

    model_path = a.model or str(Path(__file__).resolve().parents[1] / "src/headmotion/data/default_model.hmz")
    dm = load_model(model_path)
    long_video = [r for r in video if r.motion.duration >= 6.0][: 8 if a.quick else None]
    preds = [[at_rate(dm.predict(r.audio, seed=s), r.motion.fps, len(r.motion)) for s in range(a.samples)]
             for r in long_video]
    rows = rows_for("default", long_video, [p[0] for p in preds], ctx, limits=limits_of(video),
                    samples=preds if a.samples >= 2 else None, n_shifts=a.shifts)
    all_rows += [{"set": "video-seen", **r} for r in rows]
    print_table(rows, f"default model on {len(long_video)} corpus recordings ≥ 6 s (seen in training)")
    # unseen speech: compare with the pooled corpus heads (resampled to 25 fps)
    pooled = Motion(np.vstack([(r.motion if r.motion.fps == 25 else r.motion.resample(25.0)).rotvec
                               for r in video]), 25.0)
    srows = []
    for p in sorted(SPEECH.iterdir()):
        try:
            au = load_audio(p, sample_rate=16000)
        except Exception as e:  # noqa: BLE001 - one unreadable file does not stop the report
            log(f"  skip {p.name}: {e}")
            continue
        ms = [dm.predict(au, seed=s).resample(25.0) for s in range(a.samples)]
        n = len(ms[0])
        ref = Motion(pooled.rotvec[:n] if len(pooled) >= n else pooled.rotvec, 25.0)
        mask = R.speech_mask_for(au, ms[0])
        row = R.realism(ref, ms[0], speech_mask=mask, samples=[m.rotvec for m in ms] if a.samples >= 2 else None)
        row["pause_ratio_ref"] = float("nan")
        srows.append({"condition": "default", "recording": p.stem, **row})
    summ = {"condition": "default", "recording": "ALL"}
    for k in srows[0]:
        if k not in ("condition", "recording"):
            summ[k] = float(np.nanmedian([r[k] for r in srows]))
    summ["sd_ratio_mean"] = float(np.nanmean([summ[f"sd_ratio_{x}"] for x in R.AXES]))
    srows.append(summ)
    all_rows += [{"set": "speech-unseen", **r} for r in srows]
    print_table(srows, f"default model on {len(srows) - 1} unseen speech files (reference: pooled corpus heads)")
    figs["video"]["default"] = [Motion(p[0], r.motion.fps) for p, r in zip(preds, long_video)]

    # -- systems trained on real data
    sets = [("zeggs", zeg, [[i] for i in range(len(zeg))])]
    if not a.quick:
        sets.append(("video", video, speaker_folds(video, 2)))
    for tag, recs, folds in sets:
        rows = []
        for sysname in a.systems:
            t = time.time()
            try:
                out, _ = cross_validate(sysname, recs, folds, cache_dir, tag)
            except Exception as e:  # noqa: BLE001 - report and continue with the next system
                log(f"  {tag} {sysname}: FAILED {type(e).__name__}: {e}")
                continue
            ms = [out[r.id][0] for r in recs]
            rows += rows_for(sysname, recs, ms, ctx, limits=limits_of(recs), n_shifts=a.shifts)
            figs[tag][sysname] = [Motion(x, r.motion.fps) for x, r in zip(ms, recs)]
            log(f"  {tag} {sysname}: {time.time() - t:.0f} s")
        all_rows += [{"set": tag, **r} for r in rows]
        print_table(rows, f"{tag}: systems trained on the other folds, driven by held-out speech")

    if a.csv:
        write_rows_csv(all_rows, a.csv)
    if a.figures:
        from headmotion.evaluation import realism_figures as RF

        out = Path(a.figures)
        out.mkdir(parents=True, exist_ok=True)
        for tag in ("video", "zeggs") if not a.quick else ("zeggs",):
            RF.spectra_figure(figs[tag], path=out / f"realism_spectra_{tag}.png", title=tag)
            RF.speed_histogram_figure(figs[tag], path=out / f"realism_speed_{tag}.png", title=tag)
            RF.realism_coupling_scatter([r for r in all_rows if r.get("set") == tag],
                                        path=out / f"realism_vs_coupling_{tag}.png", title=tag)
        log(f"figures in {out}")


if __name__ == "__main__":
    main()
