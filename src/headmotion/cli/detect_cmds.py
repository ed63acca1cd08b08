"""``headmotion detect``: can a classifier tell generated head motion from recorded head motion?

A thin wrapper over :func:`headmotion.evaluation.detection.detectability.detectability` (the classifier
two-sample test that ``headmotion evaluate`` runs for every condition).
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from ..errors import ParameterError
from .app import app, console

MOTION_SUFFIXES = (".npz", ".json", ".csv", ".bvh", ".c3d", ".txt")


def _motions(path: Path) -> dict:
    """A corpus directory (with corpus.csv), a folder of motion files (by file stem), or one file."""
    from ..corpus import Corpus
    from ..io.motion import load_motion

    if path.is_dir() and (path / "corpus.csv").is_file():
        return {r.id: r.motion for r in Corpus.load(path)}
    if path.is_dir():
        files = sorted(p for p in path.iterdir() if p.suffix.lower() in MOTION_SUFFIXES)
        if not files:
            raise ParameterError(f"{path}: no motion files ({', '.join(MOTION_SUFFIXES)}) and no corpus.csv")
        return {p.stem: load_motion(p) for p in files}
    return {path.stem: load_motion(path)}  # one file (a missing one: load_motion's error)


@app.command("detect")
def detect_cmd(
    real: Path = typer.Argument(..., help="recorded motion: a corpus directory, a folder of motion files or one file"),
    generated: Path = typer.Argument(..., help="generated motion: a folder of motion files named like the recordings "
                                               "whose speech made them (same stem), or one file"),
    seed: int = typer.Option(0, "--seed", min=0, help="seed of the folds, classifiers and bootstrap"),
    chunk: float = typer.Option(12.0, "--chunk", min=0.0,
                                help="cut each recording into groups of this many seconds (0: whole recordings)"),
    cnn: bool = typer.Option(True, "--cnn/--no-cnn", help="also train the 1-D CNN on the raw windows"),
    figure: Optional[Path] = typer.Option(None, "--figure", help="PNG of the statistics that separate most"),
):
    """Classifier two-sample test of generated against recorded head motion (detectability)."""
    from ..evaluation.detection import detectability as D

    rm, gm = _motions(real), _motions(generated)
    res = D.detectability(rm, gm, seed=seed, chunk_s=chunk or None,
                          classifiers=D.CLASSIFIERS if cnn else ("stats",))
    console.print(f"{res.n_real} recorded and {res.n_generated} generated windows of {D.WINDOW_S:g} s in "
                  f"{res.n_groups} groups", highlight=False)
    for name, sc in res.scores.items():
        console.print(f"  {name:6s} balanced accuracy {sc.balanced_accuracy:.3f} [{sc.ba_ci[0]:.3f}, {sc.ba_ci[1]:.3f}]  "
                      f"AUC {sc.auc:.3f} [{sc.auc_ci[0]:.3f}, {sc.auc_ci[1]:.3f}]", highlight=False)
    console.print(f"detectability {res.detectability:.3f} (0.5: cannot be told apart; 1: always is)", highlight=False)
    console.print("separates most (AUC of the statistic alone): "
                  + ", ".join(f"{n} {v:.2f}" for n, v in res.top_statistics(5)), highlight=False, soft_wrap=True)
    if figure is not None:
        from ..evaluation.reporting.detectability_figures import statistics_figure

        statistics_figure(rm, gm, path=figure)
        console.print(f"figure → {figure}", highlight=False)
