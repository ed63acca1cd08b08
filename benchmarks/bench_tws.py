"""Benchmarks of template-warping synthesis (issue 4 performance targets).

    python benchmarks/bench_tws.py synth            # synth 60 s with the default model, features included
    python benchmarks/bench_tws.py stream           # mean compute per 10 ms chunk
    python benchmarks/bench_tws.py train MINUTES    # train tws-hier on a planted corpus of one speaker
    python benchmarks/bench_tws.py scaling 5 10 20 40   # each size in a fresh process: time + peak RSS

Planted corpora (:mod:`headmotion.synthetic`) tile real speech, so feature extraction costs what
it costs on real audio.  Model loading is excluded from the synthesis timing.
"""

import json
import resource
import subprocess
import sys
import time

import numpy as np


def _speech(seconds):
    from headmotion.synthetic import _speech_pool, speech_sources, tiled_speech
    from headmotion.types import Audio

    pool = _speech_pool(speech_sources(), 16000)
    return Audio(tiled_speech(pool, seconds, sample_rate=16000, rng=np.random.default_rng(0)), 16000)


def bench_synth():
    from headmotion.cli.synth_cmds import default_model_path
    from headmotion.systems import load_model

    m = load_model(default_model_path())
    a = _speech(60.0)
    m.predict(a.slice_seconds(0, 2))  # warm-up (imports)
    ts = []
    for _ in range(3):
        t = time.perf_counter()
        m.predict(a)
        ts.append(time.perf_counter() - t)
    best = min(ts)
    return {"synth_60s_seconds": best, "x_real_time": 60.0 / best, "all": ts}


def bench_stream():
    from headmotion.cli.synth_cmds import default_model_path
    from headmotion.systems import load_model

    m = load_model(default_model_path())
    a = _speech(30.0)
    st = m.stream(seed=0)
    st.push(a.samples[:160])
    n, t0 = 0, time.perf_counter()
    worst = 0.0
    for i in range(160, len(a.samples), 160):
        t = time.perf_counter()
        st.push(a.samples[i:i + 160])
        worst = max(worst, time.perf_counter() - t)
        n += 1
    st.flush()
    mean = (time.perf_counter() - t0) / n
    return {"chunk_ms": 10, "mean_ms_per_chunk": 1000 * mean, "worst_ms": 1000 * worst,
            "latency_ms": st.latency_ms}


def bench_train(minutes):
    from headmotion.synthetic import planted_corpus
    from headmotion.systems import create

    t = time.perf_counter()
    c = planted_corpus(minutes=minutes, n_recordings=max(2, int(minutes // 3)), seed=0)
    list(c)
    t_make = time.perf_counter() - t
    t = time.perf_counter()
    create("tws-hier").fit(c)
    t_fit = time.perf_counter() - t
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return {"minutes": minutes, "train_seconds": t_fit, "corpus_seconds": t_make, "peak_rss_mb": rss}


if __name__ == "__main__":
    what = sys.argv[1]
    if what == "synth":
        print(json.dumps(bench_synth()))
    elif what == "stream":
        print(json.dumps(bench_stream()))
    elif what == "train":
        print(json.dumps(bench_train(float(sys.argv[2]))))
    elif what == "scaling":
        for m in sys.argv[2:]:
            r = subprocess.run([sys.executable, __file__, "train", m], capture_output=True, text=True)
            print(r.stdout.strip() or r.stderr[-500:], flush=True)
