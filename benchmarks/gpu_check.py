"""Every network system trained on CUDA and on the CPU, the models compared, one table.

    python benchmarks/gpu_check.py [--corpus DIR] [--planted-hours 0.1] [--epochs 4]
                                   [--flow-steps 300] [--systems mfcc-dnn,cccae,...] [--out FILE.json]

Systems: mfcc-dnn, fbank-dnn, f0e-dnn, wav-dnn, cccae, ae-dnn, motion-flow.  Corpora: the real
talking-video corpus (``--corpus``, default ``~/.cache/headmotion/corpus/talking_video``, built by
``scripts/build_real_corpus.py`` from ../shared/data; skipped with a line when absent) and a planted
corpus in BEAT2's layout (``--planted-hours``, written to a temporary folder).

Each system is trained twice on each corpus: the *reference* on the CPU with its default data path
(in memory for corpora this size), and the *candidate* on CUDA — with ``train_path="streamed"`` for
the DNN systems that stream (the path a GPU takes on large corpora) and the default path for cccae,
ae-dnn and motion-flow.  Where torch sees no CUDA device the script says so and the candidate is
the streamed path on the CPU (the DNN systems that stream; the others are trained once).

Checks (those of ``tests/test_scale_training.py``): best validation loss of the candidate within
5 % of the reference's (the regressor's for the DNN systems, the flow loss for motion-flow), the
outputs on three corpus recordings correlated > 0.9 per axis, and their SD ratio per axis within
0.8–1.25.  motion-flow samples its movements, so its correlation is not a check (shown, not
judged).  A system that learns nothing on a corpus (validation loss near or above 1, its restoring
gains at their caps) can fail the SD check on any two paths or devices: its output level is set by
whichever near-flat epoch stopped first — wav-dnn on the 7.6-minute real corpus does (best epoch 0
or 1, gains capped at 6 and 8).  Sized so that one run on a GPU machine takes under 10 minutes:
the DNN systems train ``--epochs`` epochs (autoencoders included), motion-flow ``--flow-steps``
steps.

On a 2-core CPU without CUDA: ``python benchmarks/gpu_check.py --planted-hours 0.05 --epochs 2
--flow-steps 100`` (about 10 minutes, half of it motion-flow).

``--batch-scale K``, ``--bf16`` and ``--compile`` train the DNN candidates on the GPU path
(:mod:`headmotion.models.train_speed`); the checks are the same.  Without them the candidate has
the standard settings and should be the CPU model up to rounding
(``docs/decisions/gpu-training.md``).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
REAL = Path.home() / ".cache" / "headmotion" / "corpus" / "talking_video"
SYSTEMS = ("mfcc-dnn", "fbank-dnn", "f0e-dnn", "wav-dnn", "cccae", "ae-dnn", "motion-flow")
STREAMING = ("mfcc-dnn", "fbank-dnn", "f0e-dnn", "wav-dnn")


def _params(name: str, epochs: int, flow_steps: int) -> dict:
    if name == "motion-flow":
        return {"train_steps": flow_steps}
    return {"max_epochs": epochs, "patience": epochs, "ae_max_epochs": epochs, "pretrain_epochs": 1}


def _valid_loss(model) -> float:
    """The best validation loss: the regressor's (DNN systems), the flow loss (motion-flow)."""
    if hasattr(model, "train_log_"):
        return float(min(h[2] for h in model.train_log_["history"]))
    return float(min(model.history_["regressor"]["valid"]))


def _outputs(model, recs) -> np.ndarray:
    """Rotation vectors for the recordings' speech, concatenated ``(T, 3)``."""
    return np.concatenate([model.predict(r.audio, seed=0).rotvec for r in recs])


def compare(ref, cand, recs) -> dict:
    """The checks on two models: validation loss, per-axis correlation and SD ratio of their outputs."""
    a, b = _outputs(ref, recs), _outputs(cand, recs)
    n = min(len(a), len(b))
    a, b = a[:n], b[:n]
    corr = [float(np.corrcoef(a[:, j], b[:, j])[0, 1]) for j in range(3)]
    sd = [float(b[:, j].std() / a[:, j].std()) for j in range(3)]
    va, vb = _valid_loss(ref), _valid_loss(cand)
    return {"valid_ref": va, "valid_cand": vb, "valid_rel": abs(vb - va) / abs(va), "corr_min": min(corr),
            "sd_min": min(sd), "sd_max": max(sd)}


def verdict(name: str, c: dict) -> bool:
    ok = c["valid_rel"] < 0.05 and 0.8 < c["sd_min"] and c["sd_max"] < 1.25
    return ok and (name == "motion-flow" or c["corr_min"] > 0.9)


def _fit(name, corpus, params):
    from headmotion.systems import create

    t0 = time.perf_counter()
    model = create(name, **params).fit(corpus)
    return model, time.perf_counter() - t0


def _planted(folder: Path, hours: float):
    from headmotion.corpus import Corpus
    from headmotion.datasets import import_dataset
    from headmotion.datasets.planted import write_planted_beat2

    write_planted_beat2(folder / "beat2", hours=hours, take_minutes=0.5, speakers=2, seed=3)
    import_dataset("beat2", folder / "beat2", folder / "corpus", jobs=1)
    return Corpus.load(folder / "corpus")


def run(corpora: dict, systems, *, epochs: int, flow_steps: int, cuda: bool, fast: dict | None = None) -> list[dict]:
    rows = []
    for cname, corpus in corpora.items():
        recs = [corpus[i] for i in range(min(3, len(corpus)))]
        for name in systems:
            base = _params(name, epochs, flow_steps)
            row = {"corpus": cname, "system": name}
            ref_device = {"device": "cpu"}
            if cuda:
                cand = {"device": "cuda", **({"train_path": "streamed"} if name in STREAMING else {})}
            elif name in STREAMING:
                cand = {"device": "cpu", "train_path": "streamed"}
            else:
                cand = None
            if cand is not None and fast and name != "motion-flow":
                cand.update(fast)
            try:
                ref, row["ref_s"] = _fit(name, corpus, {**base, **ref_device})
                row["ref"] = "cpu"
                if cand is not None:
                    other, row["cand_s"] = _fit(name, corpus, {**base, **cand})
                    row["cand"] = f"{cand['device']}" + ("/streamed" if "train_path" in cand else "") + (
                        f"/x{cand['batch_scale']}" if cand.get("batch_scale", 1) > 1 else "")
                    row.update(compare(ref, other, recs))
                    row["ok"] = verdict(name, row)
                else:
                    row["valid_ref"] = _valid_loss(ref)
            except Exception as exc:  # noqa: BLE001 - one failing system must not hide the others
                row["error"] = f"{type(exc).__name__}: {exc}"[:200]
                row["ok"] = False
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def table(rows: list[dict]) -> str:
    head = ["corpus", "system", "ref", "s", "candidate", "s", "valid ref", "valid cand", "Δ valid", "corr min",
            "SD ratio", "check"]
    lines = [head]
    for r in rows:
        def f(k, fmt="{:.3f}", r=r):
            return fmt.format(r[k]) if k in r else "—"
        check = {True: "PASS", False: "FAIL", None: "—"}[r.get("ok")]
        if "error" in r:
            check = "FAIL: " + r["error"]
        corr = f("corr_min", "{:.3f}") + (" (samples)" if r["system"] == "motion-flow" and "corr_min" in r else "")
        sd = f"{r['sd_min']:.2f}–{r['sd_max']:.2f}" if "sd_min" in r else "—"
        lines.append([r["corpus"], r["system"], r.get("ref", "—"), f("ref_s", "{:.0f}"), r.get("cand", "—"),
                      f("cand_s", "{:.0f}"), f("valid_ref"), f("valid_cand"), f("valid_rel", "{:.1%}"), corr, sd, check])
    widths = [max(len(str(row[i])) for row in lines) for i in range(len(head))]
    out = [" | ".join(str(c).ljust(w) for c, w in zip(row, widths)) for row in lines]
    out.insert(1, "-+-".join("-" * w for w in widths))
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", type=Path, default=REAL, help="the real corpus (default: %(default)s)")
    ap.add_argument("--planted-hours", type=float, default=0.1, help="planted corpus size (0: none)")
    ap.add_argument("--epochs", type=int, default=4, help="DNN epochs (regressor, post-filter, autoencoder)")
    ap.add_argument("--flow-steps", type=int, default=300, help="motion-flow training steps")
    ap.add_argument("--systems", default=",".join(SYSTEMS), help="comma-separated systems")
    ap.add_argument("--batch-scale", type=int, default=1, help="the candidate's batch_scale (DNN systems)")
    ap.add_argument("--bf16", action="store_true", help="the candidate's precision='bf16' (DNN systems, CUDA)")
    ap.add_argument("--compile", action="store_true", help="the candidate's compile_networks (DNN systems, CUDA)")
    ap.add_argument("--out", type=Path, help="also write the rows as JSON")
    args = ap.parse_args(argv)
    import torch

    from headmotion.corpus import Corpus

    systems = [s.strip() for s in args.systems.split(",") if s.strip()]
    unknown = set(systems) - set(SYSTEMS)
    if unknown:
        ap.error(f"unknown systems {sorted(unknown)}; choose from {SYSTEMS}")
    cuda = torch.cuda.is_available()
    print(f"torch {torch.__version__}; " + (f"cuda: {torch.cuda.get_device_name(0)}" if cuda else
          "cuda was not available: the candidate is the streamed path on the CPU (DNN systems that stream)"))
    warnings.filterwarnings("ignore", category=UserWarning)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="hm-gpu-check-") as tmp:
        corpora = {}
        if (args.corpus / "corpus.csv").is_file():
            corpora["real"] = Corpus.load(args.corpus)
        else:
            print(f"real corpus absent ({args.corpus}): build it with scripts/build_real_corpus.py; skipped")
        if args.planted_hours > 0:
            corpora[f"planted {args.planted_hours:g} h"] = _planted(Path(tmp), args.planted_hours)
        fast = {"batch_scale": args.batch_scale, **({"precision": "bf16"} if args.bf16 else {}),
                **({"compile_networks": True} if args.compile else {})}
        rows = run(corpora, systems, epochs=args.epochs, flow_steps=args.flow_steps, cuda=cuda, fast=fast)
    print()
    print(table(rows))
    print(f"\n{len(rows)} rows, {sum(bool(r.get('ok')) for r in rows)} pass; {time.perf_counter() - t0:.0f} s")
    if cuda:
        print(f"peak GPU memory {torch.cuda.max_memory_allocated() / 2**20:,.0f} MB")
    if args.out:
        args.out.write_text(json.dumps(rows, indent=1))
    return 0 if all(r.get("ok", True) for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
