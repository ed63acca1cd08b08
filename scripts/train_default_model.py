"""Train the default model shipped in ``src/headmotion/data/default_model.hmz`` and write its model
card ``default_model.md`` beside it.

Training data: the talking-video corpus built by ``scripts/build_real_corpus.py`` (head pose
estimated from the face in public research clips; all speakers pooled — the default must be
speaker-independent) **without** the ``mead_lrs3`` clips (CC-BY-NC-SA-4.0: non-commercial) and
never the ZEGGS mocap take (CC BY-NC-ND: no derivatives).  Every recording must come from a folder
of :data:`SOURCES` (its source repository and the licence stated there); anything else stops the
script.

The card lists the training recordings with their sources and licences, the system and its
settings, the held-out realism and coupling figures (from ``--evaluation``: the report directory of
``headmotion evaluate`` on held-out speakers, whose rows for ``--eval-system`` are quoted) and the
model's measures on real speech it has not seen (``--speech``, default ``../shared/data/speech``:
SD, band shares, limit-cycle index, pause/speech speed, diversity of 4 samples; the reference for
the shares and Hellinger distances is the pooled training heads).

Usage::

    PYTHONPATH=src python scripts/train_default_model.py [CORPUS_DIR] --system mfcc-dnn \\
        --set variance_restore=true --evaluation docs/eval/video_speakers_seed0 --eval-system mfcc-dnn [-o OUT.hmz]
"""

from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_CORPUS = Path.home() / ".cache/headmotion/corpus/talking_video"
DEFAULT_OUT = ROOT / "src/headmotion/data/default_model.hmz"
DEFAULT_SPEECH = ROOT.parent / "shared/data/speech"

#: talking_video folder (= recording-id prefix of build_real_corpus.py) → (source repository, licence
#: as stated there; ../shared/data/README.md)
SOURCES = {
    "dfrf": ("sstzal/DFRF", "MIT"),
    "styletalk": ("FuxiVirtualHuman/styletalk", "MIT"),
    "sadtalker": ("OpenTalker/SadTalker (HDTF clips)", "Apache-2.0"),
    "mimictalk": ("yerfor/MimicTalk", "MIT"),
    "pc_avs": ("Hangz-nju-cuhk/Talking-Face_PC-AVS (VoxCeleb2-style clips)", "CC-BY-4.0"),
    "grid": ("rizkiarm/LipNet (GRID sentences)", "MIT"),
    "video_retalking": ("OpenTalker/video-retalking", "Apache-2.0"),
}
#: never trained on, and why
EXCLUDED = {
    "mead_lrs3": "filby89/spectre (MEAD / LRS3 clips), CC-BY-NC-SA-4.0: non-commercial",
    "zeggs": "ZEGGS mocap, CC BY-NC-ND 4.0: no derivatives (evaluation only)",
}


def source_of(rec_id: str) -> str | None:
    """The talking_video folder of a recording id (longest matching prefix), or None."""
    for folder in sorted(list(SOURCES) + list(EXCLUDED), key=len, reverse=True):
        if rec_id == folder or rec_id.startswith(folder + "_"):
            return folder
    return None


def parse_value(v: str):
    try:
        return json.loads(v)
    except json.JSONDecodeError:
        return v


def git_commit() -> str:
    try:
        return subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def held_out_section(eval_dir: Path, system: str) -> str:
    """The realism table and coupling line of ``system`` (and the ruler) from an evaluation report."""
    from headmotion.evaluation.protocol.protocols import EvaluationResult
    from headmotion.evaluation.reporting.report import (REALISM_COLUMNS, coupling_line, read_metrics_csv, realism_summary,
                                              realism_targets)

    if (eval_dir / "metrics.csv").is_file():
        rows = read_metrics_csv(eval_dir / "metrics.csv")
    else:  # a report kept in the repository, compressed
        import gzip
        import tempfile

        with tempfile.TemporaryDirectory() as tmp:
            (Path(tmp) / "m.csv").write_bytes(gzip.decompress((eval_dir / "metrics.csv.gz").read_bytes()))
            rows = read_metrics_csv(Path(tmp) / "m.csv")
    cfg = json.loads((eval_dir / "config.json").read_text()) if (eval_dir / "config.json").is_file() else {}
    systems = list(dict.fromkeys(r["system"] for r in rows))
    recs = sorted({r["recording"] for r in rows if r["recording"] != "ALL" and not r["recording"].startswith("speaker:")})
    res = EvaluationResult(rows=rows, config=cfg, systems=systems, recordings=recs)
    summ = realism_summary(res)
    if system not in summ:
        raise SystemExit(f"{system!r} is not in {eval_dir}/metrics.csv (systems: {systems})")
    show = [s for s in ("ground-truth", "desync", "still") if s in summ] + [system]
    lines = [f"Held-out evaluation: `{eval_dir}` — protocol {cfg.get('protocol')} "
             f"({cfg.get('folds')} folds, speakers held out: {cfg.get('protocol') == 'speakers'}), seed "
             f"{cfg.get('seed')}, {len(recs)} held-out recordings; medians over recordings.\n",
             "| condition | " + " | ".join(h for _, h, _ in REALISM_COLUMNS) + " |",
             "|---" * (len(REALISM_COLUMNS) + 1) + "|"]
    for s in show:
        d = summ[s]
        lines.append(f"| {s} | " + " | ".join("–" if not np.isfinite(d.get(k, np.nan)) else f"{d[k]:.{dg}f}"
                                            for k, _, dg in REALISM_COLUMNS) + " |")
    t = realism_targets(summ)[system]
    met = [k for k, v in t.items() if v]
    missed = [k for k, v in t.items() if v is False]
    lines.append(f"\nTargets met: {', '.join(met) or 'none'}; not met: {', '.join(missed) or 'none'}.\n")
    lines.append("Speech coupling (held-out speakers):\n")
    lines.append(coupling_line(system, summ[system]))
    return "\n".join(lines)


def unseen_speech_check(model, speech_dir: Path, pooled_heads, *, samples: int = 4,
                        skip=()) -> tuple[str, list[dict]]:
    """Measures of the model on every readable audio file of ``speech_dir`` (not in the corpus)."""
    from headmotion.errors import HeadMotionError
    from headmotion.evaluation.measures import realism as R
    from headmotion.io.audio import load_audio
    from headmotion.types import Motion

    fps = 25.0
    pooled = pooled_heads
    rows = []
    for p in sorted(speech_dir.iterdir()):
        if p.stem in skip:
            continue
        try:
            au = load_audio(p, sample_rate=16000)
        except HeadMotionError as e:
            print(f"  skip {p.name}: {e}", flush=True)
            continue
        ms = [model.predict(au, seed=s).resample(fps) for s in range(samples)]
        n = len(ms[0])
        ref = Motion(pooled.rotvec[:n], fps)
        mask = R.speech_mask_for(au, ms[0])
        r = R.realism(ref, ms[0], speech_mask=mask, samples=[m.rotvec for m in ms])
        rows.append({"file": p.name, "seconds": n / fps, **r})
    hdr = ("| file | s | SD p/y/r (°) | <0.5 Hz | 1.5–4 Hz | L1 | H speed | LC | pause | diversity |\n"
           "|---|---|---|---|---|---|---|---|---|---|\n")
    body = "".join(
        f"| {r['file']} | {r['seconds']:.0f} | {r['sd_pitch']:.1f}/{r['sd_yaw']:.1f}/{r['sd_roll']:.1f} | "
        f"{r['band_0_0.5']:.2f} | {r['band_1.5_4']:.2f} | {r['spectral_l1']:.2f} | {r['speed_hellinger']:.2f} | "
        f"{r['limit_cycle']:.2f} | {r['pause_ratio']:.2f} | {r['diversity']:.2f} |\n" for r in rows)
    med = {k: float(np.nanmedian([r[k] for r in rows])) for k in ("sd_pitch", "sd_yaw", "sd_roll", "band_0_0.5",
                                                                 "band_1.5_4", "spectral_l1", "speed_hellinger",
                                                                 "limit_cycle", "pause_ratio", "diversity")}
    body += (f"| **median** | | {med['sd_pitch']:.1f}/{med['sd_yaw']:.1f}/{med['sd_roll']:.1f} | "
             f"{med['band_0_0.5']:.2f} | {med['band_1.5_4']:.2f} | {med['spectral_l1']:.2f} | "
             f"{med['speed_hellinger']:.2f} | {med['limit_cycle']:.2f} | {med['pause_ratio']:.2f} | "
             f"{med['diversity']:.2f} |\n")
    return hdr + body, rows


def provenance(a, fit_s: float, changed: dict | None = None) -> str:
    """The card's provenance line.  A model loaded with ``--from-model`` keeps the provenance of the
    card beside it (when there is one), and the line adds when and from which commit this card was
    written; a model trained here gets a fresh line."""
    now = f"{_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC"
    cmd = f"`python scripts/train_default_model.py {shown_args(sys.argv[1:])}`"
    if fit_s == fit_s:
        return f"* **Provenance**: trained {now} from commit {git_commit()} ({fit_s:.0f} s) by {cmd}."
    old_card = Path(a.from_model).with_suffix(".md")
    earlier = [ln for ln in (old_card.read_text().splitlines() if old_card.is_file() else [])
               if ln.startswith("* **Provenance**:")]
    if earlier:
        kept = earlier[0].split("; card rewritten")[0].rstrip(".")
        what = ("fitted arrays unchanged; set " + ", ".join(f"{k}={v}" for k, v in changed.items())
                if changed else "model unchanged")
        return f"{kept}; card rewritten {now} from commit {git_commit()} ({what}) by {cmd}."
    return f"* **Provenance**: trained before (no card beside it); card written {now} from commit {git_commit()} by {cmd}."


def shown_path(path: Path) -> str:
    """``path`` as the card shows it: relative to the repository (``../shared/data/speech``), never
    the builder's own absolute path."""
    try:
        return os.path.relpath(Path(path).resolve(), ROOT)
    except ValueError:  # another drive
        return Path(path).name


def shown_args(args: list[str]) -> str:
    """The command line for the card, without the note's text and the path of a model trained before."""
    out, skip = [], False
    for x in args:
        if skip:
            skip = False
            continue
        if x in ("--note", "--from-model"):
            skip = True
            continue
        out.append(x)
    return " ".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("corpus", nargs="?", type=Path, default=DEFAULT_CORPUS)
    ap.add_argument("-o", "--output", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--system", default="tws-hier")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a system parameter (JSON value or string), repeatable")
    ap.add_argument("--evaluation", type=Path, default=None,
                    help="report directory of `headmotion evaluate` on held-out speakers (quoted in the card)")
    ap.add_argument("--eval-system", default=None, help="the condition of --evaluation to quote (default --system)")
    ap.add_argument("--speech", type=Path, default=DEFAULT_SPEECH, help="unseen speech to check the model on")
    ap.add_argument("--samples", type=int, default=4)
    ap.add_argument("--note", default="", help="a paragraph for the card (why this system was chosen)")
    ap.add_argument("--from-model", type=Path, default=None,
                    help="a model this script trained before (same corpus and system): write it and its card without "
                         "training again; --set changes settings that act at synthesis (the fitted arrays stay)")
    ap.add_argument("--skip-speech", default="video_retalking_1",
                    help="comma-separated stems of --speech files to leave out (their speech is in the corpus)")
    a = ap.parse_args(argv)

    from headmotion.corpus import Corpus
    from headmotion.systems import create
    from headmotion.types import Motion

    full = Corpus.load(a.corpus)
    keep, dropped = [], []
    for i, e in enumerate(full.entries):
        folder = source_of(e.recording)
        if folder in SOURCES:
            keep.append(i)
        elif folder in EXCLUDED:
            dropped.append((e.recording, folder))
        else:
            raise SystemExit(f"recording {e.recording!r} of {a.corpus} has no known source with a licence that "
                             f"allows shipping a model trained on it; expected one of {sorted(SOURCES)}")
    corpus = full.subset(keep)
    params = {k: parse_value(v) for k, v in (s.split("=", 1) for s in a.set)}
    print(f"{len(corpus)} recordings kept, {len(dropped)} left out ({', '.join(sorted({f for _, f in dropped}))})")
    t = time.time()
    if a.from_model is not None:
        from headmotion.systems import load_model

        model = load_model(a.from_model)
        if model.name != a.system:
            raise SystemExit(f"{a.from_model} is a {model.name} model, not {a.system}")
        changed = {k: v for k, v in params.items() if model.get_params().get(k) != v}
        if changed:  # settings that act at synthesis: the fitted arrays stay as they were
            model.set_params(**changed)
            print(f"set {changed} on the loaded model")
        fit_s = float("nan")
        print(f"loaded {a.from_model} (trained before by this script)")
    else:
        changed = {}
        model = create(a.system, **params).fit(corpus)
        fit_s = time.time() - t
        print(f"trained {a.system} in {fit_s:.0f} s")
    a.output.parent.mkdir(parents=True, exist_ok=True)
    model.save(a.output)

    # -- the card
    recs = list(corpus)
    secs = [r.duration for r in recs]
    table = "| recording | speaker | s | source (folder) | licence |\n|---|---|---|---|---|\n" + "".join(
        f"| {r.id} | {r.speaker} | {d:.1f} | {SOURCES[source_of(r.id)][0]} (`{source_of(r.id)}/`) | "
        f"{SOURCES[source_of(r.id)][1]} |\n" for r, d in zip(recs, secs))
    settings = {k: v for k, v in model.get_params().items()}
    streaming = "stream" in a.output.name
    generative = "generative" in a.output.name
    md = [f"# Model card: the {'streaming ' if streaming else ''}"
          f"{'generative' if generative else 'default'} model (`{a.output.name}`)\n",
          ("`headmotion stream` and `headmotion view --live` without `-m` use this model; "
           "`headmotion info --model stream` prints this card.\n") if streaming else
          (f"`headmotion synth speech.wav -m src/headmotion/data/{a.output.name} -o head.bvh` uses this model "
           "(`--samples K` gives K takes).\n") if generative else
          ("`headmotion synth speech.wav -o head.bvh` without `-m` uses this model; "
           "`headmotion info --model default` prints this card.\n"),
          f"* **System**: `{a.system}`; settings: `{json.dumps(settings, default=str)}`.",
          f"* **Output**: {model.frame_rate:g} frames/s; sampling is seeded (`--seed`, `--samples K`).",
          f"* **Training data**: {len(recs)} recordings, {len({r.speaker for r in recs})} speakers, "
          f"{sum(secs) / 60:.1f} min of head pose estimated from the face in public talking-head clips "
          f"(`scripts/build_real_corpus.py`, {a.corpus.name}), all speakers pooled "
          "(speaker-independent). Video-derived pose: tracking jitter of ~0.1°, 25 fps.",
          "* **Left out on purpose**: " + "; ".join(f"`{k}` — {v}" for k, v in EXCLUDED.items())
          + f" ({len(dropped)} recordings of the corpus dropped: "
          + ", ".join(sorted({f for _, f in dropped}) or ["none"]) + ").",
          "* **Licences**: as stated by each source repository (`../shared/data/README.md`); the clips behind "
          "them (HDTF, VoxCeleb2, GRID, …) carry their own terms. No clip is in this repository — only "
          + ("the head pose tracked in them (25 frames a second) and per-frame prosody of their speech (F0, energy, "
             "voicing): no audio or video." if a.system == "motion-match" else
             "the model learnt from poses estimated from them."),
          provenance(a, fit_s, changed), ""]
    if a.note:
        md += ["## Why this system\n", a.note, ""]
    if a.evaluation is not None:
        md += ["## Realism and speech coupling on held-out speakers\n",
               held_out_section(a.evaluation, a.eval_system or a.system), ""]
    if a.speech.is_dir():
        pooled = Motion(np.vstack([(r.motion if abs(r.motion.fps - 25) < 1e-9 else r.motion.resample(25.0)).rotvec
                                   for r in recs]), 25.0)
        tab, _ = unseen_speech_check(model, a.speech, pooled, samples=a.samples,
                                     skip={x.strip() for x in a.skip_speech.split(",") if x.strip()})
        md += [f"## On real speech it has not seen (`{shown_path(a.speech)}`)\n",
               f"First sample (seed 0) per file; *diversity* of {a.samples} samples (seeds 0–{a.samples - 1}) in "
               "units of the training heads' SD; shares, L1 and H speed against the pooled training heads "
               f"(recorded heads: 1.5–4 Hz share ≈ 0.05, <0.5 Hz ≈ 0.7, SD 3–4°).\n", tab, ""]
    md += ["## Training recordings\n", table,
           ("Adapt it to your own speaker (20 s or more of their speech with motion: mocap or a "
            "talking video of that person): `headmotion adapt CORPUS -o mine.hmz`; or train a model on them alone: "
            "`headmotion train CORPUS --system SYSTEM -o mine.hmz`.\n") if a.system == "motion-match" else
           ("Train on your own speaker (mocap or a talking video of that person) for speaker-specific motion: "
            "`headmotion train CORPUS --system SYSTEM -o mine.hmz`.\n")]
    card = a.output.with_suffix(".md")
    from headmotion.io.atomic import atomic_write_text

    atomic_write_text(card, "\n".join(md))
    print("saved", a.output, a.output.stat().st_size, "bytes; card", card)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
