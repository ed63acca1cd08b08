"""Choosing ``motion-match``'s settings on held-out speakers (docs/decisions/motion-matching.md).

For every evaluation seed the corpus is dealt into speaker-disjoint folds as ``headmotion
evaluate --protocol speakers`` deals it; each variant is built from a fold's training speakers and
makes four takes (seeds 0–3) of every held-out recording.  Per variant and seed it prints:

* detectability within folds (statistics classifier), the mean over the four takes;
* the pooled FCCA coupling test of each take (f0e features, 100 shifts of the motion's bridge,
  Stouffer's Z over the recordings, as ``evaluate`` pools it): p and mean excess;
* the median pairwise correlation of the four takes' paths per axis, and the median SD ratio
  (take / recording) per axis;
* the pause ratio (speed in pauses over speed in speech) pooled over the four takes, median over
  recordings, beside the recorded heads' (the realism target: within ±30 % of theirs);
* the cross-speaker coupling of each take per speech side (``--sides``: ``praat``, Praat's f0e at
  the recording's rate, the measure as before; ``own``, the frame-by-frame f0e-live reading;
  ``energy``, no pitch), each side's projections fitted on the fold's training recordings.

``--level`` adds the Praat-read twin of every variant (the same settings with ``prosody=f0e``,
``live`` off; ``--level NAME``: only variant NAME's, the level of every one) and ends with each
variant's mean cross-speaker excess over its level's, per side and seed
(docs/decisions/rulers-with-a-level.md).

A variant ``{"system": NAME, ...}`` is another registered system with those parameters, scored by
the same rulers (e.g. the ``loudness-wobble`` baseline beside the variants).

Choose on seeds that are not reported (``evaluate`` reports seeds 1 and 2):

    python scripts/motion_match_choice.py ~/.cache/headmotion/corpus/talking_video --seeds 0 3 4 \
        --variants '{"end": {"goal_path": false}, "path": {}}' -o .scratch/mm_choice
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from headmotion.align import fit_length
from headmotion.corpus import Corpus
from headmotion.evaluation.measures.cross_coupling import CrossSpeakerCCA, pooled
from headmotion.evaluation.detection.detectability import detectability, prepare, reversal_rate
from headmotion.evaluation.measures.speech_sides import parse_sides, side_features
from headmotion.evaluation.protocol.feature_table import extract_one
from headmotion.evaluation.protocol.levels import level_variants, ratio
from headmotion.evaluation.protocol.folds import make_folds
from headmotion.evaluation.measures.realism import coupling, pause_speed_ratio, pause_speed_ratio_k, speech_mask_for, stouffer
from headmotion.systems.base import create

TAKES = 4


def held_out_corpus(path: str, exclude: str, min_seconds: float) -> Corpus:
    c = Corpus.load(path)
    c = c.subset([i for i, rid in enumerate(c.ids) if not (exclude and rid.startswith(exclude))])
    return c.subset([i for i, r in enumerate(c) if r.duration >= min_seconds])


def side_feats(r, side: str) -> np.ndarray:
    """A recording's speech features of one side at its motion's rate (``praat``: f0e, as before)."""
    n, fps = len(r.motion), float(r.motion.fps)
    if side == "praat":
        return np.asarray(extract_one("f0e", r.audio, fps=fps, n_frames=n).values)
    return np.asarray(side_features(r.audio, side, fps=fps, n_frames=n).values)


def takes(corpus: Corpus, seed: int, params: dict, folds: int, sides=("praat",)):
    """recording → (recorded rotvec, [TAKES generated rotvecs], fold, f0e features, fps, speech mask,
    {side: (the fold's cross-speaker CCA of that side fitted on its training recordings, the
    recording's features of that side)})."""
    out = {}
    params = dict(params)
    system = params.pop("system", "motion-match")  # another registered system as a baseline beside the variants
    for k, (_, train, test, _) in enumerate(make_folds(corpus, "speakers", seed=seed, speaker_folds=folds)):
        model = create(system, **params).fit(train)
        cca = {side: CrossSpeakerCCA().fit([r.motion for r in train], [side_feats(r, side) for r in train],
                                           fps=float(train[0].motion.fps)) for side in sides}
        for r in test:
            n = len(r.motion)
            gen = [np.asarray(fit_length(np.asarray(model.predict(r.audio, seed=s).resample(r.motion.fps).rotvec), n))
                   for s in range(TAKES)]
            feats = side_feats(r, "praat")
            out[r.id] = (np.asarray(r.motion.rotvec), gen, k, feats, float(r.motion.fps), speech_mask_for(r.audio, r.motion),
                         {side: (cca[side], feats if side == "praat" else side_feats(r, side)) for side in sides})
    return out


def scores(made: dict, shifts: int) -> dict:
    real = {r: v[0] for r, v in made.items()}
    fps = {r: v[4] for r, v in made.items()}
    fold = {r: v[2] for r, v in made.items()}
    det, p, excess = [], [], []
    for s in range(TAKES):
        gen = {r: v[1][s] for r, v in made.items()}
        det.append(detectability(real, gen, fps=fps, seed=0, classifiers=("stats",), within=fold)
                   .scores["stats"].balanced_accuracy)
        rows = [coupling(v[0], v[3], v[1][s], n_shifts=shifts, seed=0) for v in made.values()]
        p.append(stouffer([x["fcca_p"] for x in rows], n_shifts=shifts))
        excess.append(float(np.mean([x["fcca_excess"] for x in rows])))
    by_side = {}
    for side in next(iter(made.values()))[6]:  # cross-speaker coupling: projections fitted on the fold's training speakers
        takes_ = [pooled([v[6][side][0].test(v[1][s], v[6][side][1], fps=v[4], n_shifts=shifts, seed=i)
                          for i, v in enumerate(made.values())], n_shifts=shifts) for s in range(TAKES)]
        rec_ = pooled([v[6][side][0].test(v[0], v[6][side][1], fps=v[4], n_shifts=shifts, seed=i)
                       for i, v in enumerate(made.values())], n_shifts=shifts)
        by_side[side] = {"excess": [c["excess"] for c in takes_], "p": [c["p"] for c in takes_],
                         "recorded": [rec_["excess"], rec_["p"]]}
    first = by_side.get("praat") or next(iter(by_side.values()))
    det3 = []
    for s in range(TAKES):  # both sides low-passed at 3 Hz: the tracker's jitter decides nothing
        gen = {r: v[1][s] for r, v in made.items()}
        det3.append(detectability(real, gen, fps=fps, seed=0, classifiers=("stats",), within=fold, cutoff_hz=3.0)
                    .scores["stats"].balanced_accuracy)
    corr, sdr, pause, pause_rec, rev, rev_rec = [], [], [], [], [], []
    for r, v in made.items():
        rev.append(np.mean([reversal_rate(g, fps=fps[r]) for g in v[1]], axis=0))
        rev_rec.append(reversal_rate(v[0], fps=fps[r]))
        pause.append(pause_speed_ratio_k(v[1], v[5], fps=fps[r]))
        pause_rec.append(pause_speed_ratio(v[0], v[5], fps=fps[r]))
        paths = [prepare(g, fps[r]) for g in v[1]]
        rec = prepare(v[0], fps[r])
        sdr.append(paths[0].std(axis=0) / np.maximum(rec.std(axis=0), 1e-9))
        if len(paths[0]) >= 50:
            corr.append([np.mean([np.corrcoef(paths[a][:, ax], paths[b][:, ax])[0, 1]
                                  for a in range(TAKES) for b in range(a + 1, TAKES)]) for ax in range(3)])
    return {"cross_p": first["p"], "cross_excess": first["excess"], "cross_recorded": first["recorded"],
            "cross_by_side": by_side, "detect": float(np.mean(det)), "detect_takes": det, "detect_3hz": float(np.mean(det3)),
            "reversals": np.median(rev, axis=0).tolist(), "reversals_recorded": np.median(rev_rec, axis=0).tolist(), "fcca_p": p, "fcca_excess": excess,
            "p_below_05": int(sum(x < 0.05 for x in p)), "corr": np.nanmedian(corr, axis=0).tolist(),
            "sd_ratio": np.median(sdr, axis=0).tolist(), "pause": float(np.nanmedian(pause)),
            "pause_recorded": float(np.nanmedian(pause_rec))}


def cross_cells(r: dict) -> str:
    """Per side: the 4 takes' cross-speaker excess, p and the recorded heads' (excess, p)."""
    return " | ".join(f"{' '.join(f'{e:+.3f},{p:.3f}' for e, p in zip(c['excess'], c['p']))} "
                      f"({c['recorded'][0]:+.3f},{c['recorded'][1]:.3f})" for c in r["cross_by_side"].values())


def level_table(results: dict, level_of: dict, seeds, sides) -> str:
    """Each variant's mean cross-speaker excess of its 4 takes over its level's, per side and seed."""
    lines = ["| variant | level | " + " | ".join(f"{side}: seeds {'/'.join(map(str, seeds))}" for side in sides) + " |",
             "|---|---|" + "---|" * len(sides)]
    for name, lv in level_of.items():
        cells = []
        for side in sides:
            got = [ratio(float(np.mean(results[f"{name}/{s}"]["cross_by_side"][side]["excess"])),
                         float(np.mean(results[f"{lv}/{s}"]["cross_by_side"][side]["excess"]))) for s in seeds]
            cells.append("/".join(f"{x:.2f}" if np.isfinite(x) else "–" for x in got))
        lines.append(f"| {name} | {lv} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corpus")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 3, 4])
    ap.add_argument("--variants", required=True, help='JSON: name → motion-match parameters')
    ap.add_argument("--exclude", default="mead_lrs3")
    ap.add_argument("--min-seconds", type=float, default=4.0)
    ap.add_argument("--speaker-folds", type=int, default=3)
    ap.add_argument("--shifts", type=int, default=100)
    ap.add_argument("--sides", default="all", help="speech sides of the cross-speaker coupling: praat, own, energy or all")
    ap.add_argument("--level", nargs="?", const="each", default=None,
                    help="add the Praat-read twin of every variant (or of the variant named) as the level")
    ap.add_argument("-o", "--out", required=True)
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    sides = parse_sides(a.sides)
    variants, level_of = level_variants(json.loads(a.variants), a.level)
    corpus = held_out_corpus(a.corpus, a.exclude, a.min_seconds)
    results = {}
    print("| variant | seed | detectability (mean of 4 takes) | at 3 Hz | FCCA p of 4 takes | takes p < 0.05 | "
          "take correlation p/y/r | SD ratio p/y/r | pause ratio (recorded) | reversals p/y/r (recorded) | "
          + " | ".join(f"cross-speaker excess, p of 4 takes (recorded), {side}" for side in sides) + " |")
    print("|---|---|---|---|---|---|---|---|---|---|" + "---|" * len(sides))
    for name, params in variants.items():
        for seed in a.seeds:
            r = scores(takes(corpus, seed, params, a.speaker_folds, sides), a.shifts)
            results[f"{name}/{seed}"] = r
            print(f"| {name} | {seed} | {r['detect']:.3f} | {r['detect_3hz']:.3f} | {' '.join(f'{x:.3f}' for x in r['fcca_p'])} | "
                  f"{r['p_below_05']}/{TAKES} | {'/'.join(f'{x:.2f}' for x in r['corr'])} | "
                  f"{'/'.join(f'{x:.2f}' for x in r['sd_ratio'])} | {r['pause']:.2f} ({r['pause_recorded']:.2f}) | "
                  f"{'/'.join(f'{x:.2f}' for x in r['reversals'])} "
                  f"({'/'.join(f'{x:.2f}' for x in r['reversals_recorded'])}) | {cross_cells(r)} |",
                  flush=True)
    if level_of:
        print("\nratio to level (mean cross-speaker excess of the 4 takes over the level's):\n")
        print(level_table(results, level_of, a.seeds, sides))
    (out / "choice.json").write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
