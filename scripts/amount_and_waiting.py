"""Amount and waiting on unseen speech: SD and speed of the shipped models at several --amount values
on ../shared/data/speech, their speed on 20 s of silence beside their speed in speech, and the time
adapting takes on 5 minutes of material (docs/decisions/amount-and-adapt.md).

    python scripts/amount_and_waiting.py
"""
import time, glob, numpy as np
from headmotion.synthesis import synthesize, load_model
from headmotion.io import load_audio
from headmotion.types import Audio
from headmotion.evaluation.detection.detectability import prepare
from headmotion.evaluation.measures.realism import speech_mask_for
files = sorted(glob.glob('../shared/data/speech/*.wav')) + sorted(glob.glob('../shared/data/speech/*.flac'))
print(len(files), "speech files")
def speed(x):  # deg/s, prepared (6 Hz low-pass, 25 fps), norm over axes
    return np.linalg.norm(np.diff(x, axis=0), axis=1) * 25
for name in ("default", "stream"):
    m = load_model(name)
    base_sd = None
    for a in (0.5, 1.0, 2.0, 3.0):
        sds, sps = [], []
        for f in files:
            au = load_audio(f)
            for s in range(2):
                x = prepare(synthesize(au, m, seed=s, amount=a)[0])
                sds.append(x.std(0)); sps.append(speed(x).mean())
        sd = np.mean(sds, 0)
        if a == 1.0: base_sd = sd
        print(f"{name} amount {a}: SD p/y/r {sd.round(2)} mean {sd.mean():.2f} speed {np.mean(sps):.2f} deg/s", flush=True)
    # waiting: 20 s of silence, and the model's speech speed on the speech files
    sil = Audio(np.zeros(16000 * 20, np.float32), 16000)
    sv = [speed(prepare(synthesize(sil, m, seed=s)[0])).mean() for s in range(8)]
    sp_speech = []
    for f in files:
        au = load_audio(f); mo = synthesize(au, m, seed=0)[0]
        x = prepare(mo); mask = speech_mask_for(au, mo.resample(25))[:len(x)]
        v = speed(x); sp_speech.append(v[mask[1:len(x)] & mask[:len(x)-1]].mean())
    print(f"{name} silence 20 s speed per seed {np.round(sv, 2)}; speech speed {np.nanmean(sp_speech):.2f}; ratio {np.mean(sv)/np.nanmean(sp_speech):.2f}", flush=True)
# adapt timing: 5 minutes of material
from headmotion.corpus import Corpus
from headmotion.systems.adapt import adapt
c = Corpus.load('/root/.cache/headmotion/corpus/talking_video')
idx, tot = [], 0.0
for i, r in enumerate(c):
    if tot >= 300: break
    idx.append(i); tot += r.duration
sub = c.subset(idx)
recs = list(sub)  # loaded
t = time.perf_counter(); m = adapt(sub, "default"); dt = time.perf_counter() - t
print(f"adapt on {tot:.0f} s of material ({len(idx)} recordings): {dt:.1f} s (audio/motion already read)")
