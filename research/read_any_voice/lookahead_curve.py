"""How tied to speech, and how detectable, the live head is as it reads the speech further ahead
(``motion-match``'s ``lookahead_ms``; docs/decisions/motion-matching.md, "Reading ahead").

The model is the shipped ``stream``'s settings (``live=true``; ``--set KEY=VALUE`` changes one),
built from the talking-video corpus; each lookahead (``--lookaheads``, default 0, 100, 200, 400 ms
and 1080 ms, the reach of the shipped default) is the same library re-indexed, not retrained.
For each lookahead:

* **Coupling on held-out sources** (as scripts/source_holdout_choice.py): for each source of
  ``--held`` in turn the model is built from the corpus's other sources (never ``--exclude``'s:
  ``mead_lrs3``), the speech <-> motion projections fitted on every recording not held out, per
  speech side (``--sides``); the model makes one take per seed of every held-out recording, each
  tested against the circular-shift null; the recordings of every held-out source are pooled per
  seed (mean excess, Stouffer's p).  Levels: the held-out recordings' own heads, and the
  Praat-read twin library (``prosody=f0e``, not live: headmotion.evaluation.protocol.levels), built
  and scored the same way.
* **Coupling on the speech-only set** (headmotion.evaluation.protocol.speech_only.speech_coupling):
  /work/shared/data/speech without video_retalking_1.wav (a clip of a corpus source) and
  examples/speech/*.wav; the model and its twin built from the corpus without ``--exclude``, the
  projections fitted on it; level: the twin.
* **Detectability** (as scripts/motion_match_choice.py): the corpus without ``--exclude``,
  recordings of at least 4 s, dealt into 3 speaker folds per ``--fold-seeds``; the model built from
  each fold's training speakers makes ``--takes`` takes of every held-out recording; within-fold
  detectability of the statistics classifier, the mean over the takes (0.5: not told apart).  The
  twin is scored the same way.

Writes OUT/lookahead.md (the tables), OUT/lookahead.json (every figure) and OUT/lookahead.png
(ratio to the level and detectability against the lookahead); OUT is .scratch/lookahead/.

    nice -n 10 .venv/bin/python research/read_any_voice/lookahead_curve.py          # everything
    nice -n 10 .venv/bin/python research/read_any_voice/lookahead_curve.py --held grid --seeds 0 \\
        --shifts 20 --fold-seeds 0 --takes 1 --lookaheads 0,200 --speech examples/speech/short.wav   # a dry run
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / ".scratch" / "lookahead"
CORPUS = Path.home() / ".cache/headmotion/corpus/talking_video"
SPEECH = [p for p in sorted(Path("/work/shared/data/speech").glob("*")) if p.name != "video_retalking_1.wav"] \
    + sorted((ROOT / "examples/speech").glob("*.wav"))
LOOKAHEADS = (0.0, 100.0, 200.0, 400.0, 1080.0)
LEVEL = "praat-read level"


def say(*args) -> None:
    print(*args, file=sys.stderr, flush=True)


def stream_params(sets: list[str]) -> dict:
    """The shipped ``stream`` model's parameters (its lookahead left to each point), with ``--set``'s."""
    from headmotion.synthesis import load_model

    params = load_model("stream").get_params()
    params.pop("lookahead_ms", None)
    for kv in sets:
        k, _, v = kv.partition("=")
        params[k] = json.loads(v) if v not in ("", None) else None
    return params


def fit(params: dict, corpus):
    from headmotion.systems.base import create

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return create("motion-match", **params).fit(corpus)


def at(model, lookahead_ms: float):
    """The model reading ``lookahead_ms`` ahead (a copy, its library re-indexed)."""
    return copy.copy(model).set_params(lookahead_ms=float(lookahead_ms))


def label(lookahead_ms: float) -> str:
    return f"{lookahead_ms:g} ms"


# -- coupling on held-out sources ------------------------------------------------------------------
def held_out_coupling(corpus, params, twin_params, a, sides) -> dict:
    """``{side: {label: {"excess": [per seed], "p": [per seed]}}}`` pooled over every held-out
    source's recordings, with the twin under LEVEL and the recorded heads under "recorded"."""
    from headmotion.evaluation.measures.cross_coupling import pooled
    from headmotion.evaluation.protocol.folds import source_of
    from headmotion.evaluation.protocol.speech_only import fit_side_projections, speech_features

    src = [source_of(e) for e in corpus.entries]
    never = set(a.exclude)
    results: dict = {}  # (side, label, seed) → [test results]
    for held in a.held:
        t0 = time.perf_counter()
        test = list(corpus.subset([i for i, s in enumerate(src) if s == held]))
        if not test:
            raise SystemExit(f"no recordings of source {held!r}; the corpus has {sorted(set(src))}")
        library = corpus.subset([i for i, s in enumerate(src) if s != held and s not in never])
        cca = fit_side_projections(corpus.subset([i for i, s in enumerate(src) if s != held]), sides)
        feats = {side: [speech_features(r.audio, side) for r in test] for side in sides}
        base, twin = fit(params, library), fit(twin_params, library)
        models = {label(L): at(base, L) for L in a.lookaheads} | {LEVEL: twin}
        for side in sides:
            results.setdefault((side, "recorded", None), []).extend(
                cca[side].test(r.motion, f, n_shifts=a.shifts, seed=i) for i, (r, f) in enumerate(zip(test, feats[side])))
        for name, m in models.items():
            for seed in a.seeds:
                motions = [m.predict(r.audio, seed=seed) for r in test]
                for side in sides:
                    results.setdefault((side, name, seed), []).extend(
                        cca[side].test(mo, f, n_shifts=a.shifts, seed=i)
                        for i, (mo, f) in enumerate(zip(motions, feats[side])))
        say(f"held out {held}: {len(test)} recordings, library {len(library)}, {time.perf_counter() - t0:.0f} s")
    out: dict = {}
    for (side, name, _seed), res in results.items():
        p = pooled(res, n_shifts=a.shifts)
        cell = out.setdefault(side, {}).setdefault(name, {"excess": [], "p": []})
        cell["excess"].append(float(p["excess"]))
        cell["p"].append(float(p["p"]))
    return out


# -- coupling on the speech-only set ---------------------------------------------------------------
def speech_only_coupling(corpus, params, twin_params, a, sides) -> dict:
    """``{side: {label: {"excess", "p", "ratio"}}}`` over every seed and file pooled (speech_coupling)."""
    from headmotion.evaluation.protocol.folds import source_of
    from headmotion.evaluation.protocol.speech_only import speech_coupling
    from headmotion.io import load_audio

    src = [source_of(e) for e in corpus.entries]
    library = corpus.subset([i for i, s in enumerate(src) if s not in set(a.exclude)])
    base, twin = fit(params, library), fit(twin_params, library)
    systems = {label(L): at(base, L) for L in a.lookaheads} | {LEVEL: twin}
    speech = {Path(p).stem: load_audio(p) for p in a.speech}
    rows = speech_coupling(library, systems, speech, seeds=a.seeds, n_shifts=a.shifts, sides=sides,
                           levels={name: LEVEL for name in systems if name != LEVEL})
    out: dict = {}
    for r in rows:
        if r["file"] == "ALL" and r["seed"] == "ALL" and r["degradation"] == "clean":
            out.setdefault(r["side"], {})[r["system"]] = {"excess": float(r["excess"]), "p": float(r["p"]),
                                                          "ratio": float(r["ratio"])}
    return out


# -- detectability -------------------------------------------------------------------------------
def detectabilities(corpus, params, twin_params, a) -> dict:
    """``{label: [mean over the takes, per fold seed]}``, the twin under LEVEL."""
    from headmotion.align import fit_length
    from headmotion.evaluation.detection.detectability import detectability
    from headmotion.evaluation.protocol.folds import make_folds

    names = [label(L) for L in a.lookaheads] + [LEVEL]
    out: dict = {n: [] for n in names}
    for fseed in a.fold_seeds:
        real, fps, fold, gen = {}, {}, {}, {n: [dict() for _ in range(a.takes)] for n in names}
        for k, (_, train, test, _) in enumerate(make_folds(corpus, "speakers", seed=fseed, speaker_folds=3)):
            base, twin = fit(params, train), fit(twin_params, train)
            models = {label(L): at(base, L) for L in a.lookaheads} | {LEVEL: twin}
            for r in test:
                n = len(r.motion)
                real[r.id], fps[r.id], fold[r.id] = np.asarray(r.motion.rotvec), float(r.motion.fps), k
                for name, m in models.items():
                    for s in range(a.takes):
                        rv = m.predict(r.audio, seed=s).resample(r.motion.fps).rotvec
                        gen[name][s][r.id] = np.asarray(fit_length(np.asarray(rv), n))
        for name in names:
            d = [detectability(real, gen[name][s], fps=fps, seed=0, classifiers=("stats",), within=fold)
                 .scores["stats"].balanced_accuracy for s in range(a.takes)]
            out[name].append(float(np.mean(d)))
        say(f"detectability, fold seed {fseed}: " + ", ".join(f"{n} {out[n][-1]:.3f}" for n in names))
    return out


# -- the report ----------------------------------------------------------------------------------
def _ratio(x: float, level: float) -> float:
    from headmotion.evaluation.protocol.levels import ratio

    return ratio(x, level)


def _c(x: float, fmt: str = "{:.2f}") -> str:
    return fmt.format(x) if np.isfinite(x) else "–"


def tables(res: dict, a) -> str:
    names = [label(L) for L in a.lookaheads]
    frames = {label(L): int(np.floor(L * 25 / 1000 + 1e-9)) for L in a.lookaheads}
    lines = ["# Lookahead curve: `motion-match` (the shipped `stream`'s settings) reading ahead\n",
             f"seeds {a.seeds}, {a.shifts} shifts; held-out sources {a.held}; fold seeds {a.fold_seeds}, "
             f"{a.takes} takes; never in a library: {a.exclude}\n"]
    if "held_out" in res:
        lines += ["## Coupling on held-out sources\n",
                  "| lookahead | frames | speech side | " + " | ".join(f"seed {s}: excess (p)" for s in a.seeds)
                  + " | mean excess | ratio to the Praat-read level | ratio to the recorded heads |",
                  "|---|---|---|" + "---|" * (len(a.seeds) + 3)]
        for side, by in res["held_out"].items():
            lv, rec = np.mean(by[LEVEL]["excess"]), by["recorded"]["excess"][0]
            for name in names + [LEVEL, "recorded"]:
                c = by[name]
                cells = " | ".join(f"{e:+.3f} ({p:.3g})" for e, p in zip(c["excess"], c["p"]))
                if name == "recorded":
                    cells = " | ".join([cells] + [""] * (len(a.seeds) - 1))
                mean = float(np.mean(c["excess"]))
                lines.append(f"| {name} | {frames.get(name, '')} | {side} | {cells} | {mean:+.3f} | "
                             f"{_c(_ratio(mean, lv))} | {_c(_ratio(mean, rec))} |")
        lines.append("")
    if "speech_only" in res:
        lines += ["## Coupling on the speech-only set (every seed and file pooled)\n",
                  "| lookahead | frames | speech side | excess (p) | ratio to the Praat-read level |",
                  "|---|---|---|---|---|"]
        for side, by in res["speech_only"].items():
            for name in names + [LEVEL]:
                c = by[name]
                lines.append(f"| {name} | {frames.get(name, '')} | {side} | {c['excess']:+.3f} ({c['p']:.3g}) | "
                             f"{_c(c['ratio']) if name != LEVEL else ''} |")
        lines.append("")
    if "detect" in res:
        lines += ["## Detectability within folds (statistics classifier; 0.5: not told apart)\n",
                  "| lookahead | frames | " + " | ".join(f"fold seed {s}" for s in a.fold_seeds) + " | mean |",
                  "|---|---|" + "---|" * (len(a.fold_seeds) + 1)]
        for name in names + [LEVEL]:
            d = res["detect"][name]
            lines.append(f"| {name} | {frames.get(name, '')} | " + " | ".join(f"{x:.3f}" for x in d)
                         + f" | {np.mean(d):.3f} |")
        lines.append("")
    return "\n".join(lines)


def _excess(cell: dict) -> float:
    """A cell's excess: the mean over its seeds (held-out sources) or the pooled one (speech-only)."""
    return float(np.mean(cell["excess"]))


def plot(res: dict, a, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xs = np.array(a.lookaheads)
    names = [label(L) for L in a.lookaheads]
    panels = [k for k in ("held_out", "speech_only", "detect") if k in res]
    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.4), squeeze=False)
    for ax, key in zip(axes[0], panels):
        if key == "detect":
            d = res["detect"]
            ax.plot(xs, [np.mean(d[n]) for n in names], "o-", color="C3", label="live model")
            ax.axhline(np.mean(d[LEVEL]), color="0.4", ls="--", label=LEVEL)
            ax.axhline(0.5, color="0.7", ls=":", label="chance")
            ax.set_ylabel("detectability (within folds)")
            ax.set_title("detectability")
        else:  # the excess of each speech side, its levels as lines of its colour
            for j, (side, by) in enumerate(res[key].items()):
                ax.plot(xs, [_excess(by[n]) for n in names], "o-", color=f"C{j}", label=f"{side} side")
                ax.axhline(_excess(by[LEVEL]), color=f"C{j}", ls="--", lw=1, label=f"{LEVEL}, {side}")
                if key == "held_out":
                    ax.axhline(_excess(by["recorded"]), color=f"C{j}", ls=":", lw=1, label=f"recorded heads, {side}")
            ax.axhline(0.0, color="0.7", lw=0.8)
            ax.set_ylabel("coupling: excess over the shift null")
            ax.set_title("held-out sources" if key == "held_out" else "speech-only set")
        ax.set_xlabel("lookahead (ms)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    from headmotion.corpus import Corpus
    from headmotion.evaluation.measures.speech_sides import parse_sides
    from headmotion.evaluation.protocol.levels import praat_twin_params

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", type=Path, default=CORPUS)
    ap.add_argument("--lookaheads", default=",".join(f"{x:g}" for x in LOOKAHEADS), help="milliseconds, comma-separated")
    ap.add_argument("--held", default="dfrf,grid,mimictalk,pc_avs,sadtalker,styletalk,video_retalking",
                    help="sources held out in turn (comma-separated)")
    ap.add_argument("--exclude", default="mead_lrs3", help="sources never in a library (comma-separated)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    ap.add_argument("--shifts", type=int, default=200)
    ap.add_argument("--sides", default="all", help="speech sides of the coupling: praat, own, energy or all")
    ap.add_argument("--speech", nargs="+", default=[str(p) for p in SPEECH], help="the speech-only files")
    ap.add_argument("--fold-seeds", type=int, nargs="+", default=[0, 3, 4])
    ap.add_argument("--takes", type=int, default=4)
    ap.add_argument("--min-seconds", type=float, default=4.0, help="detectability: the recordings' least length")
    ap.add_argument("--parts", default="held_out,speech_only,detect")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=JSON", help="a model parameter")
    ap.add_argument("-o", "--out", type=Path, default=OUT)
    a = ap.parse_args(argv)
    a.lookaheads = [float(x) for x in a.lookaheads.split(",") if x.strip()]
    a.held = [s.strip() for s in a.held.split(",") if s.strip()]
    a.exclude = [s.strip() for s in a.exclude.split(",") if s.strip()]
    parts = {p.strip() for p in a.parts.split(",") if p.strip()}
    sides = parse_sides(a.sides)
    params = stream_params(a.set)
    twin_params = praat_twin_params(params)
    corpus = Corpus.load(a.corpus)
    a.out.mkdir(parents=True, exist_ok=True)
    res: dict = {"params": params, "lookaheads": a.lookaheads}
    t0 = time.perf_counter()
    if "held_out" in parts:
        res["held_out"] = held_out_coupling(corpus, params, twin_params, a, sides)
    if "speech_only" in parts:
        res["speech_only"] = speech_only_coupling(corpus, params, twin_params, a, sides)
        say(f"speech-only set: {len(a.speech)} files, {time.perf_counter() - t0:.0f} s so far")
    if "detect" in parts:
        from headmotion.evaluation.protocol.folds import source_of

        kept = [i for i, e in enumerate(corpus.entries) if source_of(e) not in set(a.exclude)]
        c = corpus.subset(kept)
        c = c.subset([i for i, r in enumerate(c) if r.duration >= a.min_seconds])
        res["detect"] = detectabilities(c, params, twin_params, a)
    md = tables(res, a)
    (a.out / "lookahead.md").write_text(md)
    (a.out / "lookahead.json").write_text(json.dumps(res, indent=1, default=float))
    plot(res, a, a.out / "lookahead.png")
    print(md)
    say(f"wrote {a.out}/lookahead.md, .json, .png in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
