"""headmotion benchmarks: one command, one table.

    python benchmarks/run.py [--quick] [--out results.json] [--only GROUP,...]

Each row: what was measured, the figure, the target, PASS/FAIL, and a note; the machine (cores,
CPU model) heads the table.  Timings are in-process, after a warm-up, the median of several runs;
speech-related figures are ratios to real time (audio seconds ÷ compute seconds).

Data: the corpora are *planted-structure* corpora (:mod:`headmotion.synthetic`): real speech
(the package's examples/speech, or ../shared/data/speech when present) tiled to the length needed,
with head motion made by a known template-warping process driven by that speech.  The output says
which speech was used.  Video → pose needs a real talking-face video (../shared/data); the row is
skipped with a reason when it is absent.

Groups: startup (whole commands in fresh processes: ``--help``, ``synth``, ``stream``; startup.py),
features, synth, stream, train, memory, render, video, evaluate, server (the listening-test
server under simulated participants; skipped by a bare ``--quick``), serve (``headmotion serve``
under load; serve_bench.py), scale (corpora of 1, 4, 16 hours in BEAT2's layout, import to
training; only with ``--only scale``; ``HEADMOTION_SCALE_HOURS=1,4``), epoch (one streamed mfcc-dnn
epoch split into reading, batches, transfer, compute, on the CPU and CUDA; only with ``--only epoch``;
``HEADMOTION_EPOCH_HOURS=1,4,16``), batch (50 voice lines in one ``synthesize_batch`` call: 2 jobs
against 1, and the cost per file beyond synthesis; batch_bench.py).
``--quick`` runs a reduced set (short corpora, fewer repeats) in under 3 minutes.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from harness import Results, Row, on_local_cluster, peak_rss_of, time_median  # noqa: E402
from inputs import ROOT, SHARED, speech_audio, speech_dir  # noqa: E402


FEATURE_SETS = ("f0e", "f0e-live", "mfcc", "fbank", "wav", "prosody", "prosody-live", "lsp", "lar")
SYNTH_SYSTEMS = ("tws-basic", "tws-hier", "le2012", "cccae", "mfcc-dnn")
DNN_BENCH_PARAMS = {"max_epochs": 4, "ae_max_epochs": 4, "pretrain_epochs": 1, "patience": 2}


def planted(minutes: float, *, n_recordings: int = 6, fps: float = 100.0, seed: int = 0):
    from headmotion.synthetic import planted_corpus

    return planted_corpus(minutes=minutes, n_recordings=n_recordings, fps=fps, seed=seed, speech_dir=speech_dir())


def make_system(name: str, quick: bool):
    from headmotion.systems import create

    params = dict(DNN_BENCH_PARAMS) if name in ("cccae", "mfcc-dnn", "ae-dnn") else {}
    if quick and params:
        params.update(max_epochs=2, ae_max_epochs=2)
    return create(name, **params)


# -- groups ------------------------------------------------------------------------------------
def bench_startup(res: Results, quick: bool):
    """Whole commands in fresh processes (benchmarks/startup.py)."""
    from startup import bench_startup as run_startup

    from headmotion.cli.synth_cmds import default_stream_model_path

    run_startup(res, quick, speech_audio=speech_audio, stream_model=default_stream_model_path())


def bench_features(res: Results, quick: bool):
    from headmotion.features import extract

    audio = speech_audio(60.0)
    for name in FEATURE_SETS:
        t = time_median(lambda: extract(name, audio, fps=100.0), repeats=2 if quick else 3)
        rt = audio.duration / t
        res.add(Row("1 features", f"{name} (60 s input)", rt, "x RT", "-", None, f"{t * 1000:.0f} ms"))


def bench_synth(res: Results, quick: bool, cache: dict):
    audio = speech_audio(60.0, seed=1)
    corpus = planted(2.0 if quick else 5.0)
    systems = ("tws-basic", "tws-hier") if quick else SYNTH_SYSTEMS
    from headmotion.cli.synth_cmds import default_model_path
    from headmotion.systems import load_model

    default = load_model(default_model_path())
    t = time_median(lambda: default.predict(audio, seed=0), repeats=2 if quick else 3)
    res.add(Row("2 synth", f"shipped default model ({default.name}): features + synthesis, 60 s", audio.duration / t,
                "x RT", ">= 400x", audio.duration / t >= 400, f"{t * 1000:.0f} ms; model load excluded"))
    _bench_generative(res, audio, corpus, quick)
    for name in systems:
        t0 = time.perf_counter()
        s = make_system(name, quick).fit(corpus)
        fit_s = time.perf_counter() - t0
        cache[name] = s
        t = time_median(lambda: s.predict(audio, seed=0), repeats=2 if quick else 3)
        rt = audio.duration / t
        targeted = name != "le2012"  # targets are set for tws-* and the DNN systems
        res.add(Row("2 synth", f"{name}: features + synthesis, 60 s", rt, "x RT", ">= 200x" if targeted else "-",
                    (rt >= 200) if targeted else None,
                    f"{t * 1000:.0f} ms; trained in {fit_s:.0f} s"))
        # the model's own cost: predict minus extracting its features
        cfg = getattr(s, "feature_config_", None)
        if cfg is not None:
            from headmotion.align import n_frames

            T = n_frames(len(audio), audio.sample_rate, getattr(s, "fps_", 100.0))
            tf = time_median(lambda: cfg.extract(audio, n_frames=T), repeats=2 if quick else 3)
            own = max(t - tf, 1e-6)
            res.add(Row("3 synth only", f"{name}: synthesis given features", audio.duration / own, "x RT", "-", None,
                        f"{own * 1000:.0f} ms = predict {t * 1000:.0f} - features {tf * 1000:.0f}"))


def _generative_row(res: Results, model, audio, quick: bool, label: str, detail: str):
    """One "2 synth" row for a generative system: the median wall time of ``predict`` on ``audio``
    (after a warm-up call) and the process CPU time of one more call, target 100x real time."""
    model.predict(audio, seed=0)   # first call: warm-up (torch, caches)
    t = time_median(lambda: model.predict(audio, seed=0), repeats=2 if quick else 3)
    c0 = time.process_time()
    model.predict(audio, seed=1)
    cpu = time.process_time() - c0
    rt = audio.duration / t
    res.add(Row("2 synth", f"{label}: features + synthesis, 60 s", rt, "x RT", ">= 100x", rt >= 100,
                f"{t * 1000:.0f} ms wall, {cpu * 1000:.0f} ms CPU; {detail}"))


def _bench_generative(res: Results, audio, corpus, quick: bool):
    """The generative systems. motion-flow: the shipped generative model when present, else one
    trained briefly on the planted corpus (synthesis cost does not depend on training), one torch
    thread; motion-match: its library built from the planted corpus (25 frames a second of it,
    mirrored)."""
    from headmotion.systems import create, load_model

    path = ROOT / "src/headmotion/data/generative_model.hmz"
    if path.is_file():
        flow, what = load_model(path).set_params(n_threads=1), "shipped generative model"
    else:
        flow = create("motion-flow", train_steps=20 if quick else 100, n_threads=1).fit(corpus)
        what = "trained on the planted corpus"
    _generative_row(res, flow, audio, quick, f"motion-flow ({what})", f"{flow.sampling_steps} Euler steps per window")
    mm = create("motion-match").fit(corpus)
    _generative_row(res, mm, audio, quick, "motion-match (library of the planted corpus)",
                    f"library of {len(mm.lib_motion_)} frames, mirrored")


def _paced_latency(stream, audio, secs: float, fps: float) -> dict:
    """End-to-end latency of ``stream``: ``secs`` of ``audio`` written to a wav, paced in real time
    by the live file source, through :class:`LiveSession` (frame time to output line)."""
    import soundfile as sf

    from headmotion.live.inputs import FileSource
    from headmotion.live.session import LiveSession

    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "speech.wav"
        sf.write(wav, audio.samples[: int(secs * audio.sample_rate)], audio.sample_rate)
        src = FileSource(wav, out_rate=16000, realtime=True)
        return LiveSession(src, stream, [], fps=fps).run(max_seconds=secs + 30)["latency"]


def _chunk_costs(stream, x, chunk: int):
    """Wall and process-CPU milliseconds of every ``push`` of ``chunk`` samples.  Process CPU
    counts the BLAS threads a push wakes (they keep spinning after it; the calling thread's CPU
    alone hid them: 0.3 ms against 0.8 ms per chunk for the shipped stream model)."""
    wall, cpu = [], []
    for a in range(0, len(x), chunk):
        t0, c0 = time.perf_counter(), time.process_time()
        stream.push(x[a:a + chunk])
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - t0)
    stream.flush()
    return 1000 * np.array(wall), 1000 * np.array(cpu)


def _paired_costs(a, b, x, chunk: int):
    """Process-CPU milliseconds of every ``push`` of two streams given the same chunks in turn (which
    goes first alternates), so that what the machine's other work takes falls on both alike: run one
    after the other, the ratio of their means moved by ±0.3 between runs of the same code."""
    ca, cb = [], []
    for i, k in enumerate(range(0, len(x), chunk)):
        for s, c in ((a, ca), (b, cb)) if i % 2 == 0 else ((b, cb), (a, ca)):
            c0 = time.process_time()
            s.push(x[k:k + chunk])
            c.append(time.process_time() - c0)
    a.flush()
    b.flush()
    return 1000 * np.array(ca), 1000 * np.array(cb)


def _chunk_rows(res: Results, label: str, wall, cpu, note: str = "") -> None:
    """Two rows per stream: mean thread CPU and mean wall time per 10 ms chunk (target <= 0.5 ms
    each), with p50 / p95 / p99 in the notes.  CPU time leaves out what other processes
    take from the shared cores; wall time is what a live stream feels."""
    load = os.getloadavg()[0]
    for kind, a in (("CPU", cpu), ("wall", wall)):
        res.add(Row("4 stream", f"{label}: mean {kind} time per 10 ms chunk", float(a.mean()), "ms", "<= 0.5 ms",
                    a.mean() <= 0.5, f"p50 {np.median(a):.3f}, p95 {np.percentile(a, 95):.3f}, "
                    f"p99 {np.percentile(a, 99):.2f} ms over {len(a)} chunks; load average {load:.1f}{note}"))


def bench_causal_streams(res: Results, quick: bool, cache: dict):
    """Every causal system with its live features (the defaults of new models; motion-match with
    ``live`` and a decision every 8 frames, its library the planted corpus):
    algorithmic latency, compute per 10 ms chunk (thread CPU and wall), end-to-end latency paced in
    real time."""
    from headmotion.systems import create

    audio = speech_audio(20.0 if quick else 60.0, seed=2)
    chunk = audio.sample_rate // 100  # 10 ms
    corpus = planted(2.0)
    secs = 5.0 if quick else 15.0
    for name, params in (("tws-basic", {}), ("tws-hier", {}), ("le2012", {}), ("motion-match", {"live": True, "hop": 8})):
        s = cache.get(f"{name}-live")
        if s is None:
            import warnings

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                s = create(name, **params).fit(corpus)
            cache[f"{name}-live"] = s
        feats = s._config().name if hasattr(s, "_config") else "f0e-live"
        t0 = time.perf_counter()
        warm = s.stream(seed=0)  # the first stream of the process loads what it needs (le2012: numba)
        start_ms = 1000 * (time.perf_counter() - t0)
        warm.push(audio.samples[: 50 * chunk])  # warm-up: the first frames through every stage
        wall, cpu = _chunk_costs(s.stream(seed=0), audio.samples, chunk)
        lat_alg = s.stream(seed=0).latency_ms
        res.add(Row("4 stream", f"{name} ({feats}): algorithmic latency", lat_alg, "ms", "<= 100 ms",
                    lat_alg <= 100, "features' lookahead; the generator holds nothing back"))
        _chunk_rows(res, f"{name} ({feats})", wall, cpu, f"; first stream() of the process {start_ms:.0f} ms")
        lat = _paced_latency(s.stream(seed=0), audio, secs, float(s.frame_rate))
        res.add(Row("4 stream", f"{name} ({feats}), {secs:.0f} s paced in real time: end-to-end latency median",
                    lat["median_ms"], "ms", "<= 100 ms", lat["median_ms"] is not None and lat["median_ms"] <= 100,
                    f"p95 {lat['p95_ms']:.0f} ms, max {lat['max_ms']:.0f} ms over {lat['frames']} frames; "
                    f"frame time to emission (10 ms chunks)"))


def bench_stream(res: Results, quick: bool, cache: dict):
    bench_causal_streams(res, quick, cache)
    s = cache.get("tws-hier") or make_system("tws-hier", quick).fit(planted(2.0))
    audio = speech_audio(20.0 if quick else 60.0, seed=2)
    chunk = audio.sample_rate // 100  # 10 ms
    st = s.stream(seed=0)
    st.push(audio.samples[: 50 * chunk])  # warm-up
    st = s.stream(seed=0)
    wall, cpu = _chunk_costs(st, audio.samples, chunk)
    _chunk_rows(res, f"tws-hier ({s._config().name}, the synth group's model)", wall, cpu)
    res.add(Row("4 stream", "tws-hier: algorithmic latency", float(getattr(st, "latency_ms", float("nan"))), "ms",
                "-", None, "audio needed beyond a frame before it is final"))
    # the DNN systems stream with the lookahead of their ±25-frame context and 50-frame
    # post-filter segments (systems/dnn/streaming.py); a 25-frame block is recomputed every 250 ms
    for name in ("mfcc-dnn", "cccae"):
        d = cache.get(name) or make_system(name, True).fit(planted(2.0))
        cache[name] = d
        dst = d.stream(seed=0)
        dst.push(audio.samples[: 100 * chunk])  # warm-up (torch, features)
        dst = d.stream(seed=0)
        ms, cpu = _chunk_costs(dst, audio.samples, chunk)
        res.add(Row("4 stream", f"{name}: mean compute per 10 ms chunk", float(ms.mean()), "ms", "<= 0.5 ms",
                    ms.mean() <= 0.5, f"median {np.median(ms):.3f} ms, p99 {np.percentile(ms, 99):.2f} ms over "
                    f"{len(ms)} chunks (25 new frames computed every 25 chunks); thread CPU time mean "
                    f"{np.mean(cpu):.3f} ms"))
        res.add(Row("4 stream", f"{name}: algorithmic latency (lookahead)", float(dst.latency_ms), "ms", "-", None,
                    "(segment - 1 + context) frames + feature reach, first frame of a 25-frame block"))
    # the incremental features, pushed 10 ms at a time
    from headmotion.features.streaming import StreamingF0e

    ex = StreamingF0e(sample_rate=audio.sample_rate)
    ex.push(audio.samples[: 50 * chunk])  # warm-up
    ex = StreamingF0e(sample_rate=audio.sample_rate)
    ms, cpu = _chunk_costs(ex, audio.samples, chunk)
    _chunk_rows(res, "f0e-live features alone", ms, cpu)
    res.add(Row("4 stream", "f0e-live features: algorithmic latency", ex.latency_ms, "ms", "<= 100 ms",
                ex.latency_ms <= 100, "window + smoothing + delta lookahead, from the frame's start"))
    # end to end: real speech paced in real time through the shipped model's stream
    import soundfile as sf

    from headmotion.cli.synth_cmds import default_stream_model_path
    from headmotion.live.inputs import FileSource
    from headmotion.live.session import LiveSession
    from headmotion.systems import load_model

    m = load_model(default_stream_model_path())  # what `headmotion stream` and `view --live` use
    from threadpoolctl import threadpool_limits

    warm = m.stream(seed=0)
    warm.push(audio.samples[: 50 * chunk])  # warm-up
    wall, cpu = _chunk_costs(m.stream(seed=0), audio.samples, chunk)
    label = f"shipped streaming model ({m.name}, a decision every {getattr(m, 'hop', '?')} frames)"
    _chunk_rows(res, f"{label}, the process's BLAS threads", wall, cpu)
    with threadpool_limits(limits=1, user_api="blas"):  # as headmotion's live processes run it
        wall, cpu = _chunk_costs(m.stream(seed=0), audio.samples, chunk)
        _chunk_rows(res, f"{label}, one BLAS thread (headmotion serve, stream, view --live)", wall, cpu)
        # the same speech while the head also hears the other party (the listener, headmotion.listener)
        from headmotion.synthesis import open_stream

        other = speech_audio(20.0 if quick else 60.0, seed=3).samples[: len(audio.samples)]

        class Hearing:
            def __init__(self):
                self.s, self.k = open_stream(m, seed=0, heard_rate=audio.sample_rate), 0

            def push(self, x):
                self.s.hear(other[self.k:self.k + len(x)])
                self.k += len(x)
                return self.s.push(x)

            def flush(self):
                return self.s.flush()

        alone_cpu, hear_cpu = _paired_costs(m.stream(seed=0), Hearing(), audio.samples, chunk)
    ratio = float(hear_cpu.mean() / max(alone_cpu.mean(), 1e-9))
    res.add(Row("4 stream", f"{label}, hearing the other party too: CPU per 10 ms chunk against speaking alone",
                ratio, "x", "<= 1.5x", ratio <= 1.5,
                f"{hear_cpu.mean():.3f} ms against {alone_cpu.mean():.3f} ms per chunk (process CPU, one BLAS thread; "
                f"the two streams pushed in turn, chunk by chunk); the other party's speech heard on the same timeline"))
    secs = 5.0 if quick else 15.0
    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "speech.wav"
        sf.write(wav, audio.samples[: int(secs * audio.sample_rate)], audio.sample_rate)
        src = FileSource(wav, out_rate=int(getattr(m, "sample_rate_", 16000)), realtime=True)
        st = m.stream(seed=0)
        lat = LiveSession(src, st, [], fps=float(m.frame_rate)).run(max_seconds=secs + 30)["latency"]
    # the floor of the live pipeline once the systems use f0e-live: the same paced session with the
    # feature extractor alone as the motion stream (a frame is emitted when its features are final)
    from headmotion.types import Motion

    class FeaturesOnly:
        def __init__(self):
            self.ex = StreamingF0e(sample_rate=int(getattr(m, "sample_rate_", 16000)))
            self.latency_ms = self.ex.latency_ms

        def push(self, x):
            return Motion(np.zeros((len(self.ex.push(x)), 3)), 100.0)

        def flush(self):
            return Motion(np.zeros((len(self.ex.flush()), 3)), 100.0)

    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "speech.wav"
        sf.write(wav, audio.samples[: int(secs * audio.sample_rate)], audio.sample_rate)
        src = FileSource(wav, out_rate=int(getattr(m, "sample_rate_", 16000)), realtime=True)
        floor = LiveSession(src, FeaturesOnly(), [], fps=100.0).run(max_seconds=secs + 30)["latency"]
    res.add(Row("4 stream", f"f0e-live alone in the paced session ({secs:.0f} s): end-to-end latency median",
                floor["median_ms"], "ms", "<= 100 ms", floor["median_ms"] <= 100,
                f"p95 {floor['p95_ms']:.0f} ms; the pipeline floor once the systems use f0e-live"))
    # the same paced session through an mfcc-dnn stream (the default model's system)
    d = cache["mfcc-dnn"]
    with tempfile.TemporaryDirectory() as tmp:
        wav = Path(tmp) / "speech.wav"
        sf.write(wav, audio.samples[: int(secs * audio.sample_rate)], audio.sample_rate)
        src = FileSource(wav, out_rate=int(d.sample_rate), realtime=True)
        dst = d.stream(seed=0)
        dlat = LiveSession(src, dst, [], fps=float(d.frame_rate)).run(max_seconds=secs + 30)["latency"]
    res.add(Row("4 stream", f"mfcc-dnn, {secs:.0f} s of speech paced in real time: end-to-end latency median",
                dlat["median_ms"], "ms", "-", None,
                f"p95 {dlat['p95_ms']:.0f} ms; algorithmic {dst.latency_ms:.1f} ms (worst frame of a block)"))
    res.add(Row("4 stream", f"shipped streaming model ({m.name}), {secs:.0f} s of speech paced in real time: "
                "end-to-end latency median",
                lat["median_ms"], "ms", "<= 100 ms", lat["median_ms"] <= 100,
                f"p95 {lat['p95_ms']:.0f} ms; frame time to emission; algorithmic {st.latency_ms:.0f} ms"))


def bench_train(res: Results, quick: bool):
    minutes = (2, 4, 8) if quick else (5, 10, 20, 40)
    for name in ("tws-hier", "tws-basic"):
        times = []
        seeds = (3,) if quick else (3, 4, 5)
        for m in minutes:
            # EM iteration counts vary with the data, so one corpus per size makes the slope noisy:
            # take the median over corpora drawn with different seeds
            runs = []
            for sd in seeds:
                corpus = planted(m, n_recordings=max(4, int(m)), seed=sd)
                list(corpus)
                t0 = time.perf_counter()
                make_system(name, quick).fit(corpus)
                runs.append(time.perf_counter() - t0)
            times.append(float(np.median(runs)))
            res.add(Row("5 train", f"{name}: {m} min", times[-1], "s", "-", None,
                        f"median of {len(runs)} corpora: " + ", ".join(f"{r:.1f}" for r in runs)))
        slope = float(np.polyfit(np.log(minutes), np.log(times), 1)[0])
        tail = float(np.log(times[-1] / times[-2]) / np.log(minutes[-1] / minutes[-2]))
        res.add(Row("5 train", f"{name}: log-log slope", slope, "", "<= 1.2", slope <= 1.2,
                    f"minutes {minutes}; last doubling alone {tail:.2f}"))
        t30 = float(np.exp(np.polyval(np.polyfit(np.log(minutes), np.log(times), 1), np.log(30))))
        res.add(Row("5 train", f"{name}: 30 min (from the fit)", t30, "s", "<= 120 s", t30 <= 120,
                    "interpolated" if max(minutes) >= 30 else "extrapolated"))
    # adapting the shipped default to a speaker: 5 minutes of their speech with motion
    from headmotion.systems.adapt import adapt

    corpus = planted(5.0, n_recordings=5, seed=6)
    list(corpus)
    t0 = time.perf_counter()
    adapt(corpus, "default", min_speech_s=0)
    t = time.perf_counter() - t0
    res.add(Row("5 train", "adapt default: 5 min of material", t, "s", "<= 30 s", t <= 30,
                "headmotion adapt: feature extraction and the search tables"))
    if not quick:
        corpus = planted(10.0, n_recordings=10, seed=4)
        list(corpus)
        t0 = time.perf_counter()
        from headmotion.systems import create

        create("cccae").fit(corpus)  # default epochs / early stopping: the real training cost
        t = time.perf_counter() - t0
        res.add(Row("5 train", "cccae pipeline: 10 min", t, "s", "-", None, "default parameters"))
        res.add(Row("5 train", "cccae pipeline: 30 min (x3, linear)", 3 * t / 60, "min", "<= 15 min", 3 * t / 60 <= 15,
                    "extrapolated linearly"))


def bench_memory(res: Results, quick: bool):
    minutes = 10 if quick else 60
    code = (
        "import sys; sys.path.insert(0, %r)\n"
        "from run import planted\n"
        "from headmotion.systems import create\n"
        "c = planted(%r, n_recordings=%d, seed=5); list(c)\n"
        "create('tws-hier').fit(c)\n" % (str(Path(__file__).parent), float(minutes), max(6, minutes // 3))
    )
    rss, _ = peak_rss_of(code)
    res.add(Row("6 memory", f"peak RSS, tws-hier training on {minutes} min", rss, "MB", "<= 2048 MB", rss <= 2048,
                "fresh process incl. corpus in memory"))
    bench_long_synth(res, quick)


def long_speech_file(path: Path, minutes: float, sample_rate: int = 16000) -> Path:
    """A ``minutes``-long 16-bit wav of the example speech tiled, written block by block."""
    import numpy as np
    import soundfile as sf

    from headmotion.io import load_audio

    x = load_audio(ROOT / "examples" / "speech" / "speech_male.wav", sample_rate=sample_rate).samples
    x = np.concatenate([x, np.zeros(sample_rate // 2, np.float32)])  # half a second of pause between
    total = int(minutes * 60 * sample_rate)
    with sf.SoundFile(path, "w", samplerate=sample_rate, channels=1, subtype="PCM_16") as f:
        done = 0
        while done < total:
            n = min(len(x), total - done)
            f.write(x[:n])
            done += n
    return path


def bench_long_synth(res: Results, quick: bool):
    """``headmotion synth`` on long recordings: peak RSS and time per minute of speech."""
    import tempfile

    sizes = (10.0,) if quick else (10.0, 60.0, 180.0)
    with tempfile.TemporaryDirectory(prefix="hm-long-") as tmp:
        per_min = []
        for minutes in sizes:
            wav = long_speech_file(Path(tmp) / f"long_{int(minutes)}.wav", minutes)
            out = Path(tmp) / "out.npz"
            code = ("import time; t0 = time.perf_counter()\n"
                    "from headmotion.cli import main\n"
                    f"assert main(['synth', {str(wav)!r}, '-o', {str(out)!r}]) == 0\n"
                    "print('__T__', time.perf_counter() - t0)\n")
            rss, stdout = peak_rss_of(code, timeout=7200)
            t = float(next(l for l in stdout.splitlines() if l.startswith("__T__")).split()[1])
            per_min.append(t / minutes)
            res.add(Row("6 memory", f"peak RSS, synth (default model) on {minutes:g} min of speech", rss, "MB",
                        "<= 300 MB", rss <= 300, f"{t:.0f} s wall, {t / minutes:.2f} s per minute; this "
                        "process's own peak (VmHWM)"))
            wav.unlink()
        if len(per_min) > 1:
            ratio = per_min[-1] / per_min[0]
            res.add(Row("6 memory", f"synth time per minute, {sizes[-1]:g} min vs {sizes[0]:g} min", ratio, "x",
                        "<= 1.3 (linear)", ratio <= 1.3, "1 = exactly linear in the length"))


def bench_render(res: Results, quick: bool):
    try:
        from headmotion.render.offscreen import HeadRenderer
        from headmotion.render.video import benchmark as render_benchmark
    except Exception as exc:  # noqa: BLE001 - report, don't crash the table
        res.add(Row("7 render", "render 640x480", None, "fps", ">= 60", False, f"unavailable: {exc}"))
        return
    n = 60 if quick else 300
    rv = np.zeros((n, 3))
    rv[:, 0] = 0.2 * np.sin(np.linspace(0, 6, n))
    rv[:, 1] = 0.3 * np.sin(np.linspace(0, 4, n))
    with HeadRenderer(size=(640, 480), style="textured") as r:
        for k in range(5):
            r.render_into(rv[k:k + 1])
        t0 = time.perf_counter()
        for k in range(n):
            r.render_into(rv[k:k + 1])
        t = time.perf_counter() - t0
    res.add(Row("7 render", "render 640x480 textured, frames to RAM", n / t, "fps", ">= 60", n / t >= 60,
                f"{n} frames, OpenGL on the CPU (EGL, llvmpipe)"))
    b = render_benchmark(n_frames=n, size=(640, 480))
    res.add(Row("7 render", "render 640x480 to H.264 mp4 (incl. x264)", b["wall_fps"], "fps", ">= 60",
                b["wall_fps"] >= 60, f"CPU ms/frame: render {b['cpu_ms_render']:.1f}, ffmpeg {b['cpu_ms_ffmpeg']:.1f}; "
                f"load {b['load']:.1f}"))


def bench_video(res: Results, quick: bool):
    clips = sorted((SHARED / "talking_video" / "sadtalker").glob("*.mp4"))
    if not clips:
        res.add(Row("7 video", "video -> pose 512x512", None, "fps", ">= 25", None, f"skipped: no videos in {SHARED}"))
        return
    try:
        from headmotion.video.build import analyse_video
        from headmotion.video.decode import probe
    except Exception as exc:  # noqa: BLE001
        res.add(Row("7 video", "video -> pose 512x512", None, "fps", ">= 25", False, f"unavailable: {exc}"))
        return
    clip = clips[0]
    info = probe(clip)
    t0 = time.perf_counter()
    analyse_video(clip)
    t = time.perf_counter() - t0
    n = getattr(info, "n_frames", None) or int(round(info.duration * info.fps))
    fps = n / t
    res.add(Row("7 video", f"video -> pose, {info.width}x{info.height} ({clip.name})", fps, "fps", ">= 25", fps >= 25,
                f"{n} frames in {t:.1f} s incl. decoding + FaceMesh"))


def bench_evaluate(res: Results, quick: bool):
    from headmotion.evaluation.protocol.protocols import evaluate

    minutes = 3 if quick else 30
    corpus = planted(minutes, n_recordings=6 if quick else 10, seed=6)
    list(corpus)
    systems = ["tws-hier", "tws-basic", "shaped-noise", "desync"]
    t0 = time.perf_counter()
    local = evaluate(corpus, systems, protocol="loo", n_jobs=2, seed=0, fig48=False)
    t = time.perf_counter() - t0
    res.add(Row("8 evaluate", f"LOO, {minutes} min, {len(systems)} systems, joblib 2 jobs", t / 60, "min",
                "<= 10 min", t <= 600, ""))
    on_dask = on_local_cluster(lambda address: evaluate(corpus, systems, protocol="loo", scheduler=address, seed=0,
                                                        fig48=False))
    if on_dask is None:
        res.add(Row("8 evaluate", "same on Dask LocalCluster", None, "min", "-", None, "dask not installed"))
        return
    t = on_dask[1]
    res.add(Row("8 evaluate", "same on Dask LocalCluster (2 workers)", t / 60, "min", "<= 10 min", t <= 600,
                ""))
    del local


def bench_server(res: Results, quick: bool):
    """Listening-test server: simulated participants answering every 50 ms over
    HTTP (``benchmarks/listening_load.py``), SQLite, 1 and 4 worker processes, ``--sync full``
    (and ``normal`` with 1 worker in the full run); each setting run twice (once with
    ``--quick``), the median reported.  The load client runs on the same cores; its own CPU per
    answer is in the note, next to the server's and the load average before/after."""
    import tempfile

    import listening_load as L

    n = 100 if quick else 300
    items = 4 if quick else 8
    repeats = 1 if quick else 2
    settings = [(1, "full"), (4, "full")] + ([] if quick else [(1, "normal")])
    for workers, sync in settings:
        runs = []
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as tmp:
                cfg = L.make_test_dir(Path(tmp) / "t", n_items=items)
                db = f"sqlite:///{Path(tmp) / 'bench.sqlite'}"
                srv = L.ServerProc(cfg, db, workers=workers, sync=sync)
                try:
                    r = L.load(srv.url, n, think_s=0.05, server=srv)
                    L.check_stored(srv.answers(), r["sent"], L.pid_by_token(db))
                    assert r["answers"] == n * items and not r["errors"], r["errors"][:3]
                finally:
                    srv.stop()
            runs.append(r)

        def med(key, runs=runs):
            return float(np.median([r[key] for r in runs]))

        def each(key, fmt, runs=runs):
            return " / ".join(fmt.format(r[key]) for r in runs)

        loads = " / ".join(f"{r['load_before']:.1f}→{r['load_after']:.1f}" for r in runs)
        what = (f"SQLite --sync {sync}, {workers} worker{'s' if workers > 1 else ''}, "
                f"{n} participants x {items} trials")
        res.add(Row("9 server", f"{what}: answers/s", med("answers_per_s"), "answers/s", "-", None,
                    f"median of {len(runs)} ({each('answers_per_s', '{:.0f}')}); every answer "
                    f"stored once; load average {loads}"))
        res.add(Row("9 server", f"{what}: answer p95", med("p95_ms"), "ms", "<= 250 ms",
                    med("p95_ms") <= 250,
                    f"runs {each('p95_ms', '{:.0f}')} ms; p50 {med('p50_ms'):.0f} ms; 50 ms between "
                    f"answers; client on the same cores"))
        res.add(Row("9 server", f"{what}: server CPU per answer (state read + answer)",
                    med("steady_cpu_ms_per_answer"), "ms", "<= 1 ms", med("steady_cpu_ms_per_answer") <= 1.0,
                    f"once every participant has started; runs {each('steady_cpu_ms_per_answer', '{:.2f}')}; "
                    f"whole flow (registration, demographics, start too) "
                    f"{med('server_cpu_ms_per_answer'):.2f} ms per answer; load client "
                    f"{med('client_cpu_ms_per_answer'):.2f} ms per answer"))


def bench_serve(res: Results, quick: bool):
    """``headmotion serve`` under load: benchmarks/serve_bench.py."""
    from serve_bench import bench_serve as run_serve

    run_serve(res, quick)


def bench_avatar(res: Results, quick: bool):
    """The avatar page in Chromium on a real ``headmotion serve``: benchmarks/avatar_bench.py."""
    from avatar_bench import bench_avatar as run_avatar

    run_avatar(res, Row, quick)


def bench_scale(res: Results, quick: bool):
    from scale_bench import bench_scale as scale  # a dataset of hours: see benchmarks/scale_bench.py

    scale(res, quick, speech_dir=speech_dir())


def bench_batch(res: Results, quick: bool):
    from batch_bench import bench_batch as batch  # a voice-line library in one call: see benchmarks/batch_bench.py

    batch(res, quick, speech_dir=speech_dir())


def bench_epoch(res: Results, quick: bool):
    from scale_bench import bench_epoch as epoch  # one streamed epoch by part: see benchmarks/scale_bench.py

    epoch(res, quick, speech_dir=speech_dir())


GROUPS = ("startup", "features", "synth", "stream", "train", "memory", "render", "video", "evaluate", "server",
          "serve", "avatar", "scale", "epoch", "batch")
#: each group's label in the table (its rows' ``group``), also on the row of a group that failed
LABELS = {"startup": "0 startup", "features": "1 features", "synth": "2 synth", "stream": "4 stream",
          "train": "5 train", "memory": "6 memory", "render": "7 render", "video": "7 video",
          "evaluate": "8 evaluate", "server": "9 server", "serve": "10 serve", "avatar": "10 serve", "scale": "11 scale",
          "epoch": "12 epoch", "batch": "10 batch"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="reduced set, under 3 minutes")
    ap.add_argument("--out", type=Path, help="write the results as JSON")
    ap.add_argument("--only", help=f"comma-separated groups out of {','.join(GROUPS)}")
    args = ap.parse_args(argv)
    only = set(args.only.split(",")) if args.only else set(GROUPS)
    unknown = only - set(GROUPS)
    if unknown:
        ap.error(f"unknown groups {sorted(unknown)}; choose from {GROUPS}")
    res = Results()
    print(f"headmotion benchmarks ({'quick' if args.quick else 'full'}); machine: {res.machine['cores']} cores, "
          f"{res.machine['cpu']}")
    print(f"planted-structure corpora from real speech in {speech_dir()}")
    cache: dict = {}
    t_all = time.perf_counter()
    for g in GROUPS:
        if g not in only:
            continue
        if args.quick and g == "video":
            continue
        if args.quick and g in ("server", "serve", "avatar") and not args.only:  # minutes: only when asked
            continue
        if g in ("scale", "epoch") and not args.only:  # hours of corpus: only when asked
            continue
        fn = globals()[f"bench_{g}"]
        kwargs = {"cache": cache} if g in ("synth", "stream") else {}
        try:
            fn(res, args.quick, **kwargs)
        except Exception as exc:  # noqa: BLE001 - one failing group must not hide the others
            res.add(Row(LABELS[g], f"{g} group", None, "", "", False, f"error: {type(exc).__name__}: {exc}"[:300]))
    print()
    print(res.table())
    print(f"\ntotal {time.perf_counter() - t_all:.0f} s")
    if args.out:
        res.save(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
