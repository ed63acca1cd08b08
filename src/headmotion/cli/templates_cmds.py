"""``headmotion templates ...``: template analysis (thesis §5.1–5.3, §5.5, §5.7).

* ``encode-error CORPUS`` — Table 5.1: RMS encoding error with cosine vs piecewise-linear templates
  and the RMS amplitude of the trajectories (per axis with ``--by-axis``).
* ``analyse CORPUS -o DIR`` — §5.3 template discovery (Figs 5.4–5.6 as PNG + discovery.json) and
  the BIC of GMM structures on warping parameters (Fig 5.12).
* ``confusion CORPUS -m MODEL`` — Table 5.2 (tws-basic speed classes) or Tables 5.6 / 5.7
  (tws-hier clusters: HMM + language model vs regression Gaussians alone), given the true
  segment boundaries of the corpus.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional

import typer

from ..errors import ParameterError
from .app import console, progress_bar, templates_app


def _load_corpus(corpus: Path, speaker: Optional[str]):
    from ..corpus import Corpus

    c = Corpus.load(corpus)
    return c.filter(speaker=speaker) if speaker else c


@templates_app.command("encode-error")
def encode_error(
    corpus: Path = typer.Argument(..., help="Corpus directory."),
    speaker: Optional[str] = typer.Option(None, "--speaker"),
    by_axis: bool = typer.Option(False, "--by-axis", help="Also per rotation component."),
    json_out: Optional[Path] = typer.Option(None, "--json", help="Write the numbers as JSON."),
    fps: Optional[float] = typer.Option(None, "--fps", help="Resample the motion first (the thesis used 100 Hz)."),
):
    """Table 5.1: RMS error of encoding with cosine vs piecewise-linear templates (radians)."""
    from rich.table import Table

    from ..motion.templates import corpus_encoding_errors

    c = _load_corpus(corpus, speaker)
    res = corpus_encoding_errors([r.motion if fps is None else r.motion.resample(fps) for r in c], by_axis=by_axis)
    t = Table(title=f"Template encoding error ({res['segments']} segments, {res['frames']} samples)")
    t.add_column("")
    t.add_column("RMS error (rad)", justify="right")
    t.add_column("RMS error (deg)", justify="right")
    import math

    for label, key in (("Cosine", "cosine"), ("Piecewise linear", "linear"), ("RMS amplitude", "rms_amplitude")):
        t.add_row(label, f"{res[key]:.4f}", f"{math.degrees(res[key]):.3f}")
    console.print(t)
    if by_axis:
        for ax, r in res["axes"].items():
            console.print(f"{ax}: cosine {r['cosine']:.4f}  linear {r['linear']:.4f}  amplitude {r['rms_amplitude']:.4f}")
    if json_out:
        from ..io.atomic import atomic_write_text

        atomic_write_text(json_out, json.dumps(res, indent=2))


@templates_app.command("analyse")
def analyse_cmd(
    corpus: Path = typer.Argument(..., help="Corpus directory."),
    output: Path = typer.Option(..., "-o", "--output", help="Directory for figures and discovery.json."),
    speaker: Optional[str] = typer.Option(None, "--speaker"),
    initialisers: str = typer.Option("20,40,80", "--initialisers", help="Initialiser-set sizes for Fig 5.4 (thesis up to 250+)."),
    sets: int = typer.Option(3, "--sets", help="Random initialiser sets per size (thesis: 10)."),
    n_main: int = typer.Option(120, "--n-main", help="Initialisers for the intra/inter analysis."),
    states: int = typer.Option(4, "--states", help="HMM states per segment model (3-5)."),
    seed: int = typer.Option(0, "--seed", min=0),
    min_swing: float = typer.Option(1.0, "--min-swing", help="Smallest swing between extrema, degrees (0 = the thesis's literal segmentation; 1 suits video-derived pose)."),
    native_rate: bool = typer.Option(False, "--native-rate", help="Segment at the motion's own rate instead of 100 Hz (the thesis's)."),
):
    """§5.3 template discovery: Figs 5.4–5.6 (+ Fig 5.12 BIC) written to DIR."""
    from ..motion.discovery import analyse

    if not 3 <= states <= 5:
        raise ParameterError(f"--states must be 3, 4 or 5 (thesis §5.3); got {states}")
    try:
        sizes = tuple(int(s) for s in initialisers.split(","))
    except ValueError:
        raise ParameterError(f"--initialisers must be comma-separated integers; got {initialisers!r}") from None
    if min_swing < 0:
        raise ParameterError(f"--min-swing must be >= 0 degrees; got {min_swing}")
    c = _load_corpus(corpus, speaker)
    motions = [r.motion for r in c]
    with progress_bar("template discovery", total=None):
        res = analyse(motions, output, n_initialisers=sizes, n_sets=sets, n_init_main=n_main, n_states=states,
                      seed=seed, fps=None if native_rate else 100.0, min_swing_deg=min_swing)
    console.print(f"{res['segments']} segments; clusters chosen {res['k_selected']} with sizes {res['cluster_sizes']}")
    console.print(f"figures → {output}")


@templates_app.command("confusion")
def confusion(
    corpus: Path = typer.Argument(..., help="Corpus directory (true segment boundaries come from it)."),
    model: Path = typer.Option(..., "-m", "--model", help="A tws-basic or tws-hier model file."),
    speaker: Optional[str] = typer.Option(None, "--speaker"),
):
    """Table 5.2 (tws-basic) or Tables 5.6/5.7 (tws-hier): recognition confusion matrices (%)."""
    import numpy as np
    from rich.table import Table

    from ..systems.base import load_model

    m = load_model(model)
    c = _load_corpus(corpus, speaker)

    def show(title, conf, names):
        t = Table(title=title)
        t.add_column("true \\ predicted")
        for n in names:
            t.add_column(n, justify="right")
        t.add_column("samples", justify="right")
        for i, row in enumerate(conf):
            tot = row.sum()
            t.add_row(names[i], *[f"{100 * v / tot:.1f}%" if tot else "-" for v in row], str(int(tot)))
        console.print(t)

    if m.name == "tws-basic":
        from ..systems.tws.basic import CLASS_NAMES

        show("Table 5.2: speed-class confusion (GMM)", m.speed_class_confusion(c), list(CLASS_NAMES))
    elif m.name == "tws-hier":
        conf = m.cluster_confusion(c)
        names = [str(i + 1) for i in range(len(conf["hmm"]))]
        show("Table 5.6: cluster confusion, HMM + language model", conf["hmm"], names)
        show("Table 5.7: cluster confusion, regression Gaussians alone", conf["gmm"], names)
        for k, v in conf.items():
            console.print(f"{k} accuracy: {np.trace(v) / max(v.sum(), 1):.3f}")
    else:
        raise ParameterError(f"{model}: confusion matrices exist for tws-basic and tws-hier models, not {m.name!r}")
