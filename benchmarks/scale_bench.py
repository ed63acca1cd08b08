"""The ``scale`` group: a dataset of hours, from its own folder layout to trained systems.

Planted corpora (real speech tiled, planted head motion; :mod:`headmotion.datasets.planted`) are
written in BEAT2's layout (1-minute takes, 4 speakers, SMPL-X at 30 fps, 16 kHz speech 0.3 s longer
than the motion) at each size in ``HEADMOTION_SCALE_HOURS`` (default ``1,4,16``; ``--quick``
``0.25,0.5``); training only up to ``HEADMOTION_SCALE_TRAIN_MAX_HOURS`` when set.  Each stage runs in a fresh process per size, which reports its wall time and peak
RSS (``ru_maxrss``):

* ``import``: ``corpus import-dataset beat2`` (scan, check every pair, write the manifest);
* ``features``: ``corpus features`` for the two systems' sets (f0e-live at 30 fps for tws-hier,
  mfcc at 100 fps for mfcc-dnn), one process (``--jobs 1``: the RSS is that of one worker);
* ``train tws-hier`` and ``train mfcc-dnn`` (the default's system; 2 epochs per stage), from
  ``Corpus.load`` with the feature cache.  tws-hier trains on its seeded budget of 4 hours of
  recordings (``max_train_hours``) on the larger corpora; mfcc-dnn trains from streamed batches at
  every size (``streamed.STREAM_MIN_SECONDS`` set to 0: by default a corpus with at most an hour of
  training speech takes the in-memory path), so its rows compare that path across sizes.

Rows: seconds per hour of corpus at each size, the log-log slope of time against size (1 =
linear), and peak RSS per stage and size with its growth per hour between the two largest sizes
(target: ≤ 4 GB at 16 hours, extrapolated linearly from that growth when 16 hours were not run).
Then the smallest corpus is evaluated (``--protocol split``: one fold per speaker,
tws-basic and shaped-noise) with joblib 2 jobs and with a Dask ``LocalCluster`` of 2 workers, and
the two metric tables are compared value by value.  ``HEADMOTION_SCALE_EVAL_HOURS`` picks another of
the sizes for that comparison, ``HEADMOTION_SCALE_DIR`` a folder that keeps the corpora (else a
temporary one).

The ``epoch`` group (:func:`bench_epoch`, only with ``--only epoch``) times one epoch of mfcc-dnn
on the streamed path at each size in ``HEADMOTION_EPOCH_HOURS`` (default ``1,4,16``; ``--quick``
``0.25``) on the CPU (``HEADMOTION_EPOCH_THREADS`` torch threads, default 1, the systems'
default) and, when torch sees one, on CUDA — with the standard settings and with the GPU path's
(:data:`FAST`: batch_scale 4, bf16, compiled) — each in a fresh process (``HEADMOTION_EPOCH_DEVICES``
lists other rows, e.g. ``cpu,cpu fast`` to run the fast settings on the CPU),
and splits it by part (:class:`headmotion.systems.dnn.stream_training.EpochClock`): reading the
recordings, feature batches, transfer to the device, compute, the loop's wait for data and the
validation pass — for the regressor and for the post-filter (its two pre-training passes
included).  The corpora are the scale group's (``HEADMOTION_SCALE_DIR``; written, and their MFCCs
cached, when absent).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from harness import Results, Row, on_local_cluster, peak_rss_of

RSS_TARGET_MB = 4096.0
DNN_PARAMS = {"max_epochs": 2, "ae_max_epochs": 2, "pretrain_epochs": 1, "patience": 2}

STAGES = {
    "import": "from headmotion.datasets import import_dataset\n"
              "import_dataset('beat2', ROOT / 'beat2', ROOT / 'corpus', jobs=1)\n",
    "features": "from headmotion.corpus import Corpus\n"
                "from headmotion.features import FeatureConfig\n"
                "from headmotion.feature_cache import build_feature_cache\n"
                "build_feature_cache(Corpus.load(ROOT / 'corpus'), [FeatureConfig('f0e-live', fps=30.0), "
                "FeatureConfig('mfcc', fps=100.0)], n_jobs=1)\n",
    "train tws-hier": "from headmotion.corpus import Corpus\n"
                      "from headmotion.systems import create\n"
                      "create('tws-hier').fit(Corpus.load(ROOT / 'corpus'))\n",
    "train mfcc-dnn": "from headmotion.corpus import Corpus\n"
                      "from headmotion.systems import create\n"
                      "from headmotion.systems.dnn import streamed\n"
                      "streamed.STREAM_MIN_SECONDS = 0.0\n"
                      f"create('mfcc-dnn', **{DNN_PARAMS!r}).fit(Corpus.load(ROOT / 'corpus'))\n",
}


def train_max_hours() -> float:
    """Training stages run up to this size (``HEADMOTION_SCALE_TRAIN_MAX_HOURS``; default all)."""
    return float(os.environ.get("HEADMOTION_SCALE_TRAIN_MAX_HOURS") or "inf")


def scale_hours(quick: bool) -> tuple[float, ...]:
    text = os.environ.get("HEADMOTION_SCALE_HOURS") or ("0.25,0.5" if quick else "1,4,16")
    return tuple(float(h) for h in text.split(",") if h.strip())


def _stage(root: Path, code: str) -> tuple[float, float]:
    """(seconds, peak RSS in MB) of ``code`` in a fresh process (``ROOT`` bound to ``root``)."""
    body = ("import time\nfrom pathlib import Path\n"
            f"ROOT = Path({str(root)!r})\n_t0 = time.perf_counter()\n" + code +
            "print('__T__', time.perf_counter() - _t0)\n")
    rss, out = peak_rss_of(body)
    seconds = float(next(line for line in out.splitlines() if line.startswith("__T__")).split()[1])
    return seconds, rss


#: the GPU path's settings for the "fast" CUDA rows (headmotion.models.train_speed)
FAST = {"batch_scale": 4, "precision": "bf16", "compile_networks": True}

EPOCH_CODE = (
    "import json\n"
    "from headmotion.corpus import Corpus\n"
    "from headmotion.systems import create\n"
    "m = create('mfcc-dnn', max_epochs=1, patience=1, cross_fit=False, train_path='streamed', device=DEVICE,\n"
    "           n_threads=THREADS, **EXTRA).fit(Corpus.load(ROOT / 'corpus'))\n"
    "h = m.history_\n"
    "import torch\n"
    "gpu = torch.cuda.max_memory_allocated() / 2**20 if DEVICE == 'cuda' else 0.0\n"
    "print('__EPOCH__', json.dumps({'fit': m.fit_seconds_, 'regressor': h['regressor']['seconds'],\n"
    "                               'postfilter': h['postfilter']['seconds'], 'gpu_mb': gpu}))\n"
)


def epoch_hours(quick: bool) -> tuple[float, ...]:
    text = os.environ.get("HEADMOTION_EPOCH_HOURS") or ("0.25" if quick else "1,4,16")
    return tuple(float(h) for h in text.split(",") if h.strip())


def epoch_breakdown(root: Path, device: str, extra: dict | None = None) -> tuple[dict, float]:
    """(the fit's seconds and its two stages' ``EpochClock`` summaries, peak RSS in MB) of one
    streamed mfcc-dnn epoch on ``device`` with the parameters ``extra``, in a fresh process."""
    import json

    threads = int(os.environ.get("HEADMOTION_EPOCH_THREADS") or 1)
    body = (f"from pathlib import Path\nROOT = Path({str(root)!r})\nDEVICE = {device!r}\nTHREADS = {threads}\n"
            f"EXTRA = {dict(extra or {})!r}\n" + EPOCH_CODE)
    rss, out = peak_rss_of(body)
    line = next(x for x in out.splitlines() if x.startswith("__EPOCH__"))
    return json.loads(line.split(" ", 1)[1]), rss


def planted_with_mfcc(root: Path, hours: float, speech_dir=None) -> Path:
    """A planted corpus of ``hours`` in BEAT2's layout under ``root``, imported, its MFCCs cached
    (each step skipped when done); the corpus folder."""
    from headmotion.corpus import Corpus
    from headmotion.datasets import import_dataset
    from headmotion.datasets.planted import write_planted_beat2
    from headmotion.feature_cache import build_feature_cache
    from headmotion.features import FeatureConfig

    if not (root / "beat2" / "train_test_split.csv").is_file():
        write_planted_beat2(root / "beat2", hours=hours, take_minutes=1.0, speakers=4, seed=1, speech_dir=speech_dir)
    if not (root / "corpus" / "corpus.csv").is_file():
        import_dataset("beat2", root / "beat2", root / "corpus", jobs=1)
    build_feature_cache(Corpus.load(root / "corpus"), [FeatureConfig("mfcc", fps=100.0)], n_jobs=2)
    return root / "corpus"


def bench_epoch(res: Results, quick: bool, *, speech_dir=None) -> None:
    import torch

    from headmotion.systems.dnn.stream_training import CLOCK_PARTS

    asked = os.environ.get("HEADMOTION_EPOCH_DEVICES")  # e.g. "cpu,cpu fast": the fast path dry-run on the CPU
    devices = ([d.strip() for d in asked.split(",") if d.strip()] if asked else
               ["cpu"] + (["cuda", "cuda fast"] if torch.cuda.is_available() else []))
    if not any(d.startswith("cuda") for d in devices):
        res.add(Row("12 epoch", "cuda", None, "", "-", None, "torch sees no CUDA device: CPU rows only"))
    keep = os.environ.get("HEADMOTION_SCALE_DIR")
    with (contextlib.nullcontext(keep) if keep else tempfile.TemporaryDirectory(prefix="hm-epoch-")) as tmp:
        for h in epoch_hours(quick):
            root = Path(tmp) / f"{h:g}h"
            planted_with_mfcc(root, h, speech_dir)
            seen = {}
            for device in devices:
                got, rss = epoch_breakdown(root, device.split()[0], FAST if device.endswith("fast") else None)
                for stage in ("regressor", "postfilter"):
                    sec = got[stage]
                    parts = ", ".join(f"{k} {sec[k]:.2f}" for k in CLOCK_PARTS)
                    res.add(Row("12 epoch", f"mfcc-dnn {stage}, 1 epoch, {h:g} h, {device}", sec["total"], "s", "-",
                                None, f"{parts} s (read, batches: ahead in a thread)"))
                seen[device] = got
                res.add(Row("12 epoch", f"mfcc-dnn fit, 1 epoch, {h:g} h, {device}", got["fit"], "s", "-", None,
                            f"reading pass, both networks, tables; peak RSS {rss:,.0f} MB"))
            for dev in (d for d in devices if d in seen and d != "cpu"):
                speed = seen["cpu"]["regressor"]["total"] / seen[dev]["regressor"]["total"]
                fit = seen["cpu"]["fit"] / seen[dev]["fit"]
                res.add(Row("12 epoch", f"regressor epoch, {dev} against the CPU, {h:g} h", speed, "x",
                            ">= 10 at 16 h", speed >= 10 if h >= 16 else None, f"whole fit {fit:.1f}x"))
                res.add(Row("12 epoch", f"whole fit, {dev} against the CPU, {h:g} h", fit, "x", ">= 5 at 16 h",
                            fit >= 5 if h >= 16 else None, ""))
            for dev in (d for d in devices if d in seen and d != "cpu"):
                mb = seen[dev]["gpu_mb"]
                res.add(Row("12 epoch", f"peak GPU memory, {dev}, {h:g} h", mb, "MB", "<= 16384 at 16 h",
                            mb <= 16384 if h >= 16 else None, "torch.cuda.max_memory_allocated over the fit"))


def _slope(hours, times) -> float:
    return float(np.polyfit(np.log(hours), np.log(times), 1)[0]) if len(hours) > 1 else float("nan")


def bench_scale(res: Results, quick: bool, *, speech_dir=None) -> None:
    from headmotion.datasets.planted import write_planted_beat2

    hours = scale_hours(quick)
    times: dict[str, list[float]] = {s: [] for s in STAGES}
    rss: dict[str, list[float]] = {s: [] for s in STAGES}
    keep = os.environ.get("HEADMOTION_SCALE_DIR")
    with (contextlib.nullcontext(keep) if keep else tempfile.TemporaryDirectory(prefix="hm-scale-")) as tmp:
        roots = []
        for h in hours:
            root = Path(tmp) / f"{h:g}h"
            t0 = time.perf_counter()
            if not (root / "beat2" / "train_test_split.csv").is_file():
                write_planted_beat2(root / "beat2", hours=h, take_minutes=1.0, speakers=4, seed=1,
                                    speech_dir=speech_dir)
            res.add(Row("11 scale", f"planted BEAT2 folder, {h:g} h", time.perf_counter() - t0, "s", "-", None,
                        f"{int(round(h * 60))} takes of 1 min, 4 speakers"))
            for stage, code in STAGES.items():
                if stage.startswith("train") and h > train_max_hours():
                    continue
                t, r = _stage(root, code)
                times[stage].append(t)
                rss[stage].append(r)
                res.add(Row("11 scale", f"{stage}: {h:g} h", t / h, "s per h", "-", None,
                            f"{t:.1f} s; peak RSS {r:,.0f} MB"))
            roots.append(root)
        for stage in STAGES:
            done = hours[:len(times[stage])]
            s = _slope(done, times[stage])
            res.add(Row("11 scale", f"{stage}: log-log slope of time", s, "", "<= 1.1 (linear)",
                        None if np.isnan(s) else s <= 1.1, f"hours {list(done)}"))
            # growth between the two largest sizes: a bounded path saturates (its budgets fill) above
            # the smallest, so the first-to-last line would extrapolate that fill to 60 hours
            per_h = (rss[stage][-1] - rss[stage][-2]) / (done[-1] - done[-2]) if len(done) > 1 else 0.0
            at16 = rss[stage][-1] + max(per_h, 0.0) * (16.0 - done[-1])
            res.add(Row("11 scale", f"{stage}: peak RSS at {done[-1]:g} h", rss[stage][-1], "MB",
                        "<= 4096 MB at 16 h", at16 <= RSS_TARGET_MB,
                        f"{', '.join(f'{x:,.0f}' for x in rss[stage])} MB; {per_h:+.0f} MB per h, so "
                        f"{at16:,.0f} MB at 16 h, {rss[stage][-1] + max(per_h, 0.0) * (60.0 - done[-1]):,.0f} at 60 h"
                        + (" (extrapolated)" if done[-1] < 16 else "")))
        k = hours.index(float(os.environ.get("HEADMOTION_SCALE_EVAL_HOURS") or hours[0]))
        _bench_parallel_evaluation(res, roots[k] / "corpus", hours[k])


def _bench_parallel_evaluation(res: Results, corpus_dir: Path, hours: float) -> None:
    from headmotion.corpus import Corpus
    from headmotion.evaluation.protocol.protocols import evaluate

    corpus = Corpus.load(corpus_dir)
    kw = dict(protocol="split", seed=0, n_shifts=20, feature_sets=[], samples=0, fig48=False)
    systems = ["tws-basic", "shaped-noise"]
    t0 = time.perf_counter()
    local = evaluate(corpus, systems, n_jobs=2, **kw)
    t_local = time.perf_counter() - t0
    res.add(Row("11 scale", f"evaluate {hours:g} h, split protocol, joblib 2 jobs", t_local, "s", "-", None,
                f"{local.config['folds']} folds, {len(local.recordings)} test recordings"))
    on_dask = on_local_cluster(lambda address: evaluate(corpus, systems, scheduler=address, **kw))
    if on_dask is None:
        res.add(Row("11 scale", "same on Dask LocalCluster", None, "s", "-", None, "dask not installed"))
        return
    dask, t_dask = on_dask
    key = lambda r: (r["system"], r["recording"], r["metric"])  # noqa: E731
    a = {key(r): r["value"] for r in local.rows}
    b = {key(r): r["value"] for r in dask.rows}
    same = a.keys() == b.keys() and all(np.isclose(a[k], b[k], equal_nan=True, rtol=0, atol=1e-9) for k in a)
    res.add(Row("11 scale", "same on Dask LocalCluster (2 workers)", t_dask, "s", "same metrics", same,
                f"{len(a)} metric values compared; joblib {t_local:.0f} s"))
