"""Post-stage sweep for the default system (mfcc-dnn) on held-out speakers of the video corpus
(issue 14, third session): the network is trained once per fold (3 speaker-disjoint folds, the
same folds as ``headmotion evaluate --protocol speakers --speaker-folds 3 --seed 0``), its raw
normalised output cached, and post stages are compared on the same output, 4 synthesis seeds.

    PYTHONPATH=src nice python scripts/diagnosis_i14/dnn_band_sweep.py [--variants a,b] [--seeds 4]
    # the product's networks (two training seeds) with other drift settings:
    PYTHONPATH=src nice python scripts/diagnosis_i14/dnn_band_sweep.py --variants drift:0.2:4:zero,drift:0.2:8:zero,drift:0.2:4:eval,drift:0.2:8:eval
    # the shaper's liveliness adaptation (prior seconds, 0 = off) and largest speed-up (fourth session):
    PYTHONPATH=src nice python scripts/diagnosis_i14/dnn_band_sweep.py --variants adapt:0:1.2:zero,adapt:5:1.2:zero,adapt:0:1.2:eval,adapt:5:1.2:eval

Prints one line per variant: band shares, L1, SD ratios, H speed (per recording median and
pooled over the corpus, GENEA-style), LC, pause ratio, diversity, pooled FCCA p per seed.
"""

from __future__ import annotations

import argparse
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from realism_report import at_rate, rows_for  # noqa: E402

from headmotion.corpus import Corpus  # noqa: E402
from headmotion.evaluation import realism as R  # noqa: E402
from headmotion.evaluation.protocols import make_folds  # noqa: E402
from headmotion.motion import speed_shaping  # noqa: E402
from headmotion.systems import create, load_model  # noqa: E402
from headmotion.systems import dnn_post  # noqa: E402
from headmotion.systems.dnn_stream import DnnPostStages  # noqa: E402
from headmotion.types import Motion  # noqa: E402

HOME = Path.home() / ".cache/headmotion/i14_band"


def corpus():
    c = Corpus.load(Path.home() / ".cache/headmotion/corpus/talking_video")
    c = c.subset([i for i, r in enumerate(c) if not r.id.startswith("mead_lrs3")])
    return c.subset([i for i, r in enumerate(c) if r.duration >= 4.0])


def fold_data():
    """Per fold: model path, train (raw y, motion y) and test (recording, raw y, energy)."""
    f = HOME / "folds.pkl"
    if f.exists():
        return pickle.loads(f.read_bytes())
    from headmotion.systems.dnn import _n_frames
    from headmotion.systems.dnn_stream import frame_energy_db
    from headmotion.io.audio import resample

    HOME.mkdir(parents=True, exist_ok=True)
    out = []
    for k, (name, train, test, _) in enumerate(make_folds(corpus(), "speakers", seed=0, speaker_folds=3)):
        mp = HOME / f"fold{k}.hmz"
        if mp.exists():
            model = load_model(mp)
        else:
            t = time.time()
            model = create("mfcc-dnn").fit(train)
            model.save(mp)
            print(f"fold {k} ({name}) fitted in {time.time() - t:.0f} s", flush=True)

        def raw(audio, model=model):
            T = _n_frames(len(audio.samples), audio.sample_rate, 100.0)
            return np.asarray(model._network_values(model._extract(audio, T)), dtype=np.float64), T

        tr = []
        for r in train:
            y, T = raw(r.audio)
            m = r.motion.resample(100.0) if abs(r.motion.fps - 100) > 1e-9 else r.motion
            rv = np.asarray(m.rotvec)[:T]
            if len(rv) < T:
                rv = np.vstack([rv, np.repeat(rv[-1:], T - len(rv), 0)])
            tr.append((y, np.asarray(model.motion_norm_.transform(rv), dtype=np.float64)))
        te = []
        for r in test:
            y, T = raw(r.audio)
            x = r.audio.samples
            if r.audio.sample_rate != int(model.sample_rate_):
                x = resample(x, r.audio.sample_rate, int(model.sample_rate_))
            e = frame_energy_db(x, sample_rate=int(model.sample_rate_), fps=100.0, n_frames=T)
            te.append((r.id, y, e))
        out.append({"model": str(mp), "train": tr, "test": te})
    f.write_bytes(pickle.dumps(out))
    return out


# -- variants -------------------------------------------------------------------------------------
def post_stage(model, spec, bank, seed):
    """The variance-restoring and drift stage of ``spec`` (global ratio or band gains ``bank``)."""
    share, tau = spec.get("share", 0.15), spec.get("tau", 4.0)
    rng = np.random.default_rng(seed) if share > 0 else None
    gains = dict(gv=model.gv_) if spec["kind"] == "gv" else dict(band_gains=bank)
    return dnn_post.CausalPost(**gains, share=share, sd=model.motion_sd_, fps=100.0, tau_s=tau, rng=rng)


def synth(model, y, e, seed, spec, bank=None, table=None):
    """Post stages of ``spec`` on normalised raw output ``y`` → rotvec at 100 fps."""
    stages = DnnPostStages(model, seed)
    stages.post = post_stage(model, spec, bank, seed)
    if spec.get("idle") is not None:
        stages.settler.idle = spec["idle"]
    if table is None:
        return stages.push(y, e)
    z = stages.post.push(y)
    rv = np.asarray(model.motion_norm_.inverse_transform(z), dtype=np.float64)
    rv = speed_shaping.SpeedShaper(table, fps=100.0, follow_s=spec.get("follow", 0.5), lag=spec.get("lag", 1)).push(rv)
    flags = stages.tracker.push(np.asarray(e, dtype=np.float64)[:, None])
    return stages.settler.push(rv, stages.weight.push(flags))


def shaping_table(model, fd, spec, bank):
    """Speed map from the post output on the training recordings (no pauses) to their motion."""
    pred, targ = [], []
    for k, (y, m) in enumerate(fd["train"]):
        pred.append(np.asarray(model.motion_norm_.inverse_transform(post_stage(model, spec, bank, k).push(y)),
                               dtype=np.float64))
        targ.append(np.asarray(model.motion_norm_.inverse_transform(m), dtype=np.float64))
    # the variants were measured before the product bounded the speed-up (SPEED_MAX_GAIN): unbounded
    return speed_shaping.speed_map(pred, targ, lag=spec.get("lag", 1), max_gain=spec.get("max_gain"))


def product_models(which: str, *, cached: bool) -> list:
    """The product's fold networks fitted by this checkout (``zero``: random_state 0; ``eval``: the
    training seeds ``headmotion evaluate --seed 0`` uses); with ``cached``, kept as
    ``prod{which}{k}.hmz`` (delete them after changing the fit)."""
    from headmotion.evaluation.protocols import _sub_seed

    out = []
    for k, (name, train, _, _) in enumerate(make_folds(corpus(), "speakers", seed=0, speaker_folds=3)):
        f = HOME / f"prod{which}{k}.hmz"
        if cached and f.exists():
            out.append(load_model(f))
            continue
        model = create("mfcc-dnn", random_state=0 if which == "zero" else _sub_seed(0, name, "mfcc-dnn")).fit(train)
        if cached:
            HOME.mkdir(parents=True, exist_ok=True)
            model.save(f)
        out.append(model)
    return out


def predict_held_out(models, recs, a):
    """``predict`` of each fold's network on its held-out recordings, seeds 0 … a.seeds − 1."""
    refs, first, samples = [], [], []
    folds = make_folds(corpus(), "speakers", seed=0, speaker_folds=3)
    for model, (_, _, test, _) in zip(models, folds):
        for r in test:
            outs = [at_rate(model.predict(r.audio, seed=s), r.motion.fps, len(r.motion)) for s in range(a.seeds)]
            refs.append(recs[r.id])
            first.append(outs[0])
            samples.append(outs)
    return refs, first, samples


def product(tag, recs, ctx, a):
    """``prod:zero|eval``: the product code end to end, networks fitted afresh."""
    t0 = time.time()
    report(tag, *predict_held_out(product_models(tag.split(":")[-1], cached=False), recs, a), ctx, a, t0)


def drift(tag, recs, ctx, a):
    """``drift:SHARE:TAU:zero|eval``: the cached product networks with another drift share / time
    constant (the speed map stays the one fitted with the defaults)."""
    t0 = time.time()
    _, share, tau, which = tag.split(":")
    models = product_models(which, cached=True)
    for m in models:
        m.set_params(drift_share=float(share), drift_tau_s=float(tau))
    report(tag, *predict_held_out(models, recs, a), ctx, a, t0)


def report(v, refs, first, samples, ctx, a, t0):
    rows = rows_for(v, refs, first, ctx, samples=samples if a.seeds > 1 else None, n_shifts=a.shifts)
    s = rows[-1]
    sp_r = np.concatenate([R.speed(r.motion) for r in refs])
    sp_c = np.concatenate([R.speed(Motion(m, r.motion.fps)) for m, r in zip(first, refs)])
    hp = R.hellinger_values(sp_r, sp_c)
    rec_rows = [r for r in rows if r.get("recording") != "ALL"]
    l1p = R.mean_shares_distance(*[[[r[f"band_{b}{x}"] for b in R.BAND_NAMES] for r in rec_rows] for x in ("_ref", "")])
    ps = [rows_for(v, refs, [x[sd] for x in samples], ctx, n_shifts=a.shifts)[-1]["fcca_p_pooled"]
          for sd in range(1, a.seeds)]
    print(f"{v:10s} 1.5-4={s['band_1.5_4']:.3f} <0.5={s['band_0_0.5']:.2f} L1={s['spectral_l1']:.2f} L1pool={l1p:.3f} "
          f"SD={s['sd_ratio_pitch']:.2f}/{s['sd_ratio_yaw']:.2f}/{s['sd_ratio_roll']:.2f} "
          f"Hs={s['speed_hellinger']:.2f} Hpool={hp:.3f} LC={s['limit_cycle']:.2f} pause={s['pause_ratio']:.2f} "
          f"div={s.get('diversity', float('nan')):.2f} FCCAx={s['fcca_excess']:+.3f} "
          f"p={s['fcca_p_pooled']:.3f} " + " ".join(f"{p:.3f}" for p in ps)
          + f" lccax={s['lcca_excess']:+.3f} p={s['lcca_p_pooled']:.3f}  ({time.time() - t0:.0f} s)", flush=True)
    qs = [5, 10, 25, 50, 75, 90, 95, 99]
    print(f"{'':10s} speed quantiles {qs} °/s: recorded " + " ".join(f"{x:.1f}" for x in np.percentile(sp_r, qs))
          + " | system " + " ".join(f"{x:.1f}" for x in np.percentile(sp_c, qs)), flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--variants", default="cur")
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--shifts", type=int, default=100)
    a = ap.parse_args()
    folds = fold_data()
    recs = {r.id: r for r in corpus()}
    ctx: dict = {}
    specs = {
        "cur": dict(kind="gv", share=0.15, tau=4.0),
        "gv0": dict(kind="gv", share=0.0),
        "band": dict(kind="band", share=0.15, tau=4.0),
        "band0": dict(kind="band", share=0.0),
        "bshape": dict(kind="band", share=0.15, tau=4.0, shape=True),
        "bshape1": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=1.0),
        "bshape25": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25),
        "bsl4": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25, lag=4),
        "bsl8": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25, lag=8),
        "bsl4f5": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.5, lag=4),
        "bsl4r0": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25, lag=4, reserve=0.0),
        "bsl4t8": dict(kind="band", share=0.15, tau=8.0, shape=True, follow=0.25, lag=4),
        "bsl4s2": dict(kind="band", share=0.2, tau=4.0, shape=True, follow=0.25, lag=4),
        "bsl6": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25, lag=6),
        "r0i5": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25, lag=4, reserve=0.0, idle=0.5),
        "r0i6": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25, lag=4, reserve=0.0, idle=0.6),
        "r0l6i5": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25, lag=6, reserve=0.0, idle=0.5),
        "r0s2i5": dict(kind="band", share=0.2, tau=4.0, shape=True, follow=0.25, lag=4, reserve=0.0, idle=0.5),
        "r0i45": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25, lag=4, reserve=0.0, idle=0.45),
        "q_f15": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.15, lag=4, reserve=0.0, idle=0.45),
        "q_l3": dict(kind="band", share=0.15, tau=4.0, shape=True, follow=0.25, lag=3, reserve=0.0, idle=0.45),
        "gshape": dict(kind="gv", share=0.15, tau=4.0, shape=True),
        "band25": dict(kind="band", share=0.25, tau=4.0),
        "band25_2": dict(kind="band", share=0.25, tau=2.0),
        "band_cap3": dict(kind="band", share=0.15, tau=4.0, cap=3.0),
        "band_cap10": dict(kind="band", share=0.15, tau=4.0, cap=10.0),
    }
    for v in a.variants.split(","):
        if v.startswith("param:"):  # param:KEY=VALUE[;KEY=VALUE]:zero|eval — the cached product networks
            import json
            t0 = time.time()
            models = product_models(v.split(":")[2], cached=True)
            kv = dict(x.split("=", 1) for x in v.split(":")[1].split(";"))
            for m in models:
                m.set_params(**{k: json.loads(x) for k, x in kv.items()})
            report(v, *predict_held_out(models, recs, a), ctx, a, t0)
            continue
        if v.startswith("b0:"):  # b0:FACTOR:zero|eval — the cached product networks, slow_band_gain = FACTOR
            t0 = time.time()
            models = product_models(v.split(":")[2], cached=True)
            for m in models:
                m.set_params(slow_band_gain=float(v.split(":")[1]))
            report(v, *predict_held_out(models, recs, a), ctx, a, t0)
            continue
        if v.startswith("adapt:"):  # adapt:SECONDS:GAIN:zero|eval — the shaper's liveliness
            # adaptation prior (0: off) and largest speed-up
            keep = speed_shaping.SHAPING_ADAPT_S, speed_shaping.SPEED_MAX_GAIN
            _, sec, gain, _ = v.split(":")
            speed_shaping.SHAPING_ADAPT_S, speed_shaping.SPEED_MAX_GAIN = float(sec) or None, float(gain)
            product(v, recs, ctx, a)
            speed_shaping.SHAPING_ADAPT_S, speed_shaping.SPEED_MAX_GAIN = keep
            continue
        if v.startswith("prod"):
            product(v, recs, ctx, a)
            continue
        if v.startswith("drift:"):
            drift(v, recs, ctx, a)
            continue
        spec = specs[v]
        t0 = time.time()
        refs, first, samples = [], [], []
        for fd in folds:
            model = load_model(fd["model"])
            bank = None
            if spec["kind"] == "band":
                bank = dnn_post.band_gains([y for y, _ in fd["train"]], [m for _, m in fd["train"]],
                                           fps=100.0, share=spec.get("reserve", spec.get("share", 0.0)), cap=spec.get("cap", dnn_post.BAND_CAP))
            table = shaping_table(model, fd, spec, bank) if spec.get("shape") else None
            for rid, y, e in fd["test"]:
                r = recs[rid]
                outs = [at_rate(Motion(synth(model, y, e, s, spec, bank, table), 100.0), r.motion.fps, len(r.motion))
                        for s in range(a.seeds)]
                refs.append(r)
                first.append(outs[0])
                samples.append(outs)
        report(v, refs, first, samples, ctx, a, t0)

if __name__ == "__main__":
    main()
