"""Amount and waiting on unseen speech: SD and speed of the shipped models at several --amount values
on ../shared/data/speech, and their speed through 20 s of silence beside their speed in speech
(docs/decisions/amount-and-adapt.md; the time adapting takes: ``benchmarks/run.py --only train``).

    python scripts/amount_and_waiting.py
"""
import glob
from pathlib import Path

import numpy as np

from headmotion.evaluation.detection.detectability import prepare
from headmotion.evaluation.measures.waiting import waiting
from headmotion.io import load_audio
from headmotion.synthesis import load_model, synthesize

SPEECH = Path(__file__).resolve().parents[2] / "shared" / "data" / "speech"
files = sorted(glob.glob(str(SPEECH / "*.wav"))) + sorted(glob.glob(str(SPEECH / "*.flac")))
speech = [load_audio(f) for f in files]
print(len(files), "speech files")
for name in ("default", "stream"):
    m = load_model(name)
    for a in (0.5, 1.0, 2.0, 3.0):
        sds, sps = [], []
        for au in speech:
            for s in range(2):
                x = prepare(synthesize(au, m, seed=s, amount=a)[0])  # degrees, 6 Hz low-pass, 25 fps
                sds.append(x.std(0))
                sps.append(np.linalg.norm(np.diff(x, axis=0), axis=1).mean() * 25)
        sd = np.mean(sds, 0)
        print(f"{name} amount {a}: SD p/y/r {sd.round(2)} mean {sd.mean():.2f} speed {np.mean(sps):.2f} deg/s", flush=True)
    w = waiting(m, seeds=range(8), speech=speech)
    print(f"{name} silence 20 s speed per seed {w.speed.round(2)}; ratio to its speed in speech {w.ratio:.2f}; "
          f"loop index {w.loop.round(2)}", flush=True)
