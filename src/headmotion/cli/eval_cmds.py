"""``headmotion evaluate`` and ``headmotion stats`` (thesis §4.3, §5.9, §3.5; paper §4.3).

Thin wrappers over :func:`headmotion.evaluation.protocol.protocols.evaluate` / :mod:`.report` and
:func:`headmotion.evaluation.corpus_stats.corpus_stats`; the heavy modules are imported inside
the commands.  ``--systems`` names conditions as :mod:`headmotion.evaluation.protocol.condition_specs`
resolves them: ``headmotion evaluate corpus/ --systems default,stream,mine.hmz,desync -o r/`` scores
the shipped models and a model file on every held-out recording, without retraining, beside the
desync anchor.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import ParameterError
from .app import app, console, progress_bar


@app.command("evaluate")
def evaluate_cmd(
    corpus_dir: Path = typer.Argument(..., help="corpus directory (with corpus.csv)"),
    systems: str = typer.Option(..., "--systems", "-s",
                                help="comma-separated conditions: systems trained on every fold (tws-hier, mfcc-dnn, …; "
                                     "with parameters as NAME[KEY=VALUE;...], e.g. 'mfcc-dnn,mfcc-dnn[drift_share=0.3]', "
                                     "same training and synthesis seeds), anchors (desync, shifted, other-speaker, "
                                     "shaped-noise, still), and trained models scored as they are, without retraining: "
                                     "the shipped 'default' and 'stream' models or a model file (mine.hmz). "
                                     "A system name always means training that system"),
    output: Path = typer.Option(..., "-o", "--output", help="report directory (metrics.csv, report.md, figures/)"),
    protocol: str = typer.Option("loo", "--protocol",
                                 help="loo (leave one recording out, thesis §5.9), split (paper §4.1, per speaker), dataset "
                                      "(the corpus's own split column: train on train + valid, report on test) "
                                      "speakers (leave speakers out; see --speaker-folds) or sources (leave each "
                                      "source out in turn: the manifest's source column)"),
    speaker_folds: int = typer.Option(0, "--speaker-folds",
                                      help="with --protocol speakers: number of speaker-disjoint folds (0 = one per speaker)"),
    folds_at_pauses: int = typer.Option(0, "--folds-at-pauses",
                                        help="cut every recording into N folds at its pauses first (a single long take, "
                                             "e.g. the ZEGGS mocap); then loo is leave-one-fold-out"),
    samples: int = typer.Option(4, "--samples", help="predictions per recording for the diversity measure (<2: none)"),
    exclude: Optional[str] = typer.Option(None, "--exclude",
                                          help="comma-separated recording-id prefixes to leave out (e.g. mead_lrs3)"),
    min_seconds: float = typer.Option(0.0, "--min-seconds", help="leave out recordings shorter than this"),
    features: str = typer.Option("f0e", "--features", help="feature set for Forced CCA"),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler address, e.g. tcp://host:8786"),
    jobs: int = typer.Option(1, "--jobs", "-j", help="folds in parallel on this machine (-1 = all cores)"),
    seed: int = typer.Option(0, "--seed", min=0, help="seed of everything random (same seed, same report)"),
    shifts: int = typer.Option(200, "--shifts", help="circular shifts per chance level"),
    window: float = typer.Option(3.0, "--window", help="local CCA window in seconds (3 s = 300 frames at 100 fps)"),
    speaker: Optional[str] = typer.Option(None, "--speaker", help="evaluate only this speaker"),
    feature_table: Optional[str] = typer.Option(
        None, "--feature-table", help="comma-separated feature sets for the paper Table 1 (default: all; 'none' to skip)"),
    no_figures: bool = typer.Option(False, "--no-figures", help="skip the PNG figures"),
    save_motions: bool = typer.Option(False, "--save-motions",
                                      help="also write every condition's held-out motion as motions/CONDITION/RECORDING.npz"),
    strict: bool = typer.Option(False, "--strict", help="stop when a system fails on a fold (default: warn, go on)"),
    no_detectability: bool = typer.Option(False, "--no-detectability",
                                          help="skip the classifier two-sample test of every condition against the "
                                               "recorded motion"),
    sides: str = typer.Option("all", "--sides",
                              help="speech sides of the cross-speaker coupling, comma-separated: praat (the --features "
                                   "set, f0e: the measure as before), own (the frame-by-frame f0e-live reading), "
                                   "energy (no pitch); 'all'"),
    level: Optional[bool] = typer.Option(None, "--level/--no-level",
                                         help="add each motion-match condition's Praat-read library (prosody=f0e) as "
                                              "its level (default: with --protocol sources)"),
):
    """Cross-validate systems on a corpus and write metrics.csv, report.md and figures.

    Trained models (the shipped 'default' and 'stream', or a .hmz file) are scored as they are on
    every held-out recording of every fold, so they line up with the systems trained per fold."""
    from ..corpus import Corpus
    from ..evaluation.measures.speech_sides import parse_sides
    from ..evaluation.protocol.protocols import evaluate
    from ..evaluation.reporting.report import write_report

    from ..systems.spec import split_systems

    names = split_systems(systems)
    if not names:
        raise ParameterError("--systems needs at least one system name")
    if protocol not in ("loo", "split", "dataset", "speakers", "sources"):
        raise ParameterError(f"--protocol must be loo, split, dataset, speakers or sources; got {protocol!r}")
    if folds_at_pauses < 0 or folds_at_pauses == 1:
        raise ParameterError(f"--folds-at-pauses must be 0 (off) or ≥ 2; got {folds_at_pauses}")
    corpus = Corpus.load(corpus_dir)
    if speaker:
        corpus = corpus.filter(speaker=speaker)
    corpus = without_prefixes(corpus, exclude)
    if min_seconds > 0:
        corpus = corpus.subset([i for i, r in enumerate(corpus) if r.duration >= min_seconds])
    if not len(corpus):
        raise ParameterError(f"no recordings of {corpus_dir} left to evaluate after --speaker/--exclude/--min-seconds")
    pause_warns: list[str] = []
    if folds_at_pauses:
        from ..evaluation.protocol.pause_folds import split_corpus_at_pauses

        corpus, pause_warns = split_corpus_at_pauses(corpus, folds_at_pauses)
        console.print(f"folds at pauses: {', '.join(f'{r.id} {r.duration:.1f} s' for r in corpus)}", highlight=False,
                      soft_wrap=True)
    fsets = None
    if feature_table is not None:
        fsets = [] if feature_table.strip().lower() == "none" else [f.strip() for f in feature_table.split(",") if f.strip()]
    with progress_bar("evaluating") as update:
        result = evaluate(corpus, names, protocol=protocol, features=features, n_jobs=jobs, scheduler=scheduler,
                          seed=seed, n_shifts=shifts, window_s=window, feature_sets=fsets, strict=strict,
                          samples=samples, speaker_folds=speaker_folds, detectability=not no_detectability,
                          speech_sides=parse_sides(sides), level=protocol == "sources" if level is None else level,
                          progress=lambda done, total, desc: update(done, total=total, description=desc))
    result.warnings[:0] = pause_warns
    if folds_at_pauses:
        result.config["folds_at_pauses"] = folds_at_pauses
    out = write_report(result, output, figures=not no_figures, title=f"headmotion evaluation of {corpus_dir}",
                       save_motions=save_motions)
    console.print(f"{len(result.recordings)} held-out recordings, {result.config['folds']} folds, "
                  f"{result.timings.get('total_wall', 0):.1f} s")
    for s in result.systems:
        console.print(f"  {s:16s} NMSE {result.mean(s, 'nmse'):6.3f}  local CCA {result.mean(s, 'cca_local'):5.3f} "
                      f"(chance {result.mean(s, 'cca_local_null_mean'):5.3f})  FCCA {result.mean(s, 'fcca'):5.3f} "
                      f"(chance {result.mean(s, 'fcca_null_mean'):5.3f})", highlight=False, soft_wrap=True)
    from ..evaluation.reporting.report import coupling_line, realism_summary

    summ = realism_summary(result)
    for s in result.systems:
        if s in summ:
            console.print("  " + coupling_line(s, summ[s])[2:].replace("**", ""), highlight=False, soft_wrap=True)
    for s in result.systems:
        line = detectability_line(s, result)
        if line:
            console.print("  " + line, highlight=False, soft_wrap=True)
    for w in result.warnings[:5]:
        console.print(f"[yellow]warning:[/] {w}", highlight=False, soft_wrap=True)
    if len(result.warnings) > 5:
        console.print(f"[yellow]… {len(result.warnings) - 5} more warnings in report.md[/]")
    if out["motions"]:
        console.print(f"wrote {len(out['motions'])} held-out motions under {Path(output) / 'motions'}")
    console.print(f"wrote {out['report']} and {out['metrics']}")


def without_prefixes(corpus, exclude: str | None):
    """``corpus`` without the recordings whose ids start with one of the comma-separated prefixes
    of ``exclude`` (``--exclude``)."""
    if not exclude:
        return corpus
    prefixes = tuple(p.strip() for p in exclude.split(",") if p.strip())
    return corpus.subset([i for i, rid in enumerate(corpus.ids) if not rid.startswith(prefixes)])


def detectability_line(system: str, result) -> str:
    """``name: detectability D (floor F, +A above); 3 Hz …; reversals p/y/r`` from the pooled rows,
    '' when the condition has none of them."""
    import math

    def v(metric: str) -> float:
        return result.mean(system, metric)

    parts = []
    if math.isfinite(v("detect")):
        d = f"detectability {v('detect'):.2f}"
        if math.isfinite(v("detect_floor")):
            d += f" (floor {v('detect_floor'):.2f}, {v('detect_above_floor'):+.2f} above)"
        parts.append(d)
    if math.isfinite(v("detect_3hz")):
        d = f"at 3 Hz {v('detect_3hz'):.2f}"
        if math.isfinite(v("detect_3hz_floor")):
            d += f" (floor {v('detect_3hz_floor'):.2f}, {v('detect_3hz_above_floor'):+.2f} above)"
        parts.append(d)
    rev = [v(f"reversals_{ax}") for ax in ("pitch", "yaw", "roll")]
    if any(math.isfinite(x) for x in rev):
        parts.append("reversals p/y/r " + "/".join(f"{x:.2f}" for x in rev))
    return f"{system}: " + "; ".join(parts) if parts else ""


@app.command("stats")
def stats_cmd(
    corpus_dir: Path = typer.Argument(..., help="corpus directory (with corpus.csv)"),
    output: Path = typer.Option(..., "-o", "--output", help="report directory (stats.md, CSVs, figures/)"),
    jobs: int = typer.Option(1, "--jobs", "-j", help="recordings analysed in parallel (-1 = all cores)"),
    no_speaking_rate: bool = typer.Option(False, "--no-speaking-rate", help="skip syllable-nuclei speaking rates"),
    seed: int = typer.Option(0, "--seed", min=0, help="seed of the iterative MDS and of the chance levels"),
    feature_table: Optional[str] = typer.Option(
        None, "--feature-table", help="comma-separated feature sets for the paper Table 1 (default: all; 'none' to skip)"),
    window: float = typer.Option(3.0, "--window", help="local CCA window in seconds for the feature table"),
    shifts: int = typer.Option(200, "--shifts", help="circular shifts per chance level of the feature table"),
    no_figures: bool = typer.Option(False, "--no-figures", help="skip the PNG figures"),
):
    """Thesis §3.5 corpus statistics: lengths, speaking rate, distributions, cross-entropy distances, MDS,
    and the feature ↔ motion local CCA of every feature set (paper Table 1)."""
    from ..corpus import Corpus
    from ..evaluation.corpus_stats import corpus_stats
    from ..evaluation.reporting.stats_report import write_stats

    fsets = None
    if feature_table is not None:
        fsets = [] if feature_table.strip().lower() == "none" else [f.strip() for f in feature_table.split(",") if f.strip()]
    corpus = Corpus.load(corpus_dir)
    with progress_bar("statistics", total=len(corpus) + 1) as update:
        st = corpus_stats(corpus, speaking_rate=not no_speaking_rate, n_jobs=jobs, seed=seed, feature_sets=fsets,
                          window_s=window, n_shifts=shifts,
                          progress=lambda done, total, desc: update(done, total=total, description=desc))
    out = write_stats(st, output, figures=not no_figures)
    rows = {p["condition"]: p for p in st.pairs}
    console.print(f"{len(st.recordings)} recordings; MDS stress-1 {st.stress1:.3f}; within-speaker distance "
                  f"{rows['Within speaker']['mean']:.3f} vs between speakers {rows['Between speakers']['mean']:.3f}",
                  highlight=False, soft_wrap=True)
    for w in st.warnings[:5]:
        console.print(f"[yellow]warning:[/] {w}", highlight=False, soft_wrap=True)
    if len(st.warnings) > 5:
        console.print(f"[yellow]… {len(st.warnings) - 5} more warnings in {out['report'].name}[/]")
    console.print(f"wrote {out['report']}")
