"""Speed shaping for the template systems (issue 14, fourth session): the DNN product's speed shaper
(:class:`headmotion.motion.speed_shaping.SpeedShaper`) with a quantile map fitted on each fold's
*training* speech (the system's own synthesis against the training heads), applied to the held-out
speakers' synthesis — same folds as ``headmotion evaluate --protocol speakers --speaker-folds 3
--seed 0``.  Fitted systems and their syntheses are cached under ~/.cache/headmotion/i14_tws.

    PYTHONPATH=src nice python scripts/diagnosis_i14/tws_shaper_sweep.py [--systems tws-basic,tws-hier]
        [--gains 0,1.2,2]   # 0 = no shaping

Prints, per system and largest speed-up, the realism line of dnn_band_sweep (pooled speed
Hellinger, L1, SD ratios, pause ratio, pooled FCCA p) and the pooled speed quantiles.
"""

from __future__ import annotations

import argparse
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from dnn_band_sweep import corpus  # noqa: E402
from realism_report import at_rate, rows_for  # noqa: E402

from headmotion.evaluation import realism as R  # noqa: E402
from headmotion.evaluation.protocols import _sub_seed, make_folds  # noqa: E402
from headmotion.systems import create  # noqa: E402
from headmotion.motion import speed_shaping  # noqa: E402
from headmotion.types import Motion  # noqa: E402

HOME = Path.home() / ".cache/headmotion/i14_tws"
TAG = ""  # the cache's tag (--tag: which product settings the syntheses were made with)


def syntheses(system: str, seed: int = 0):
    """Per fold: the training recordings' synthesis and motion, the held-out ones' synthesis (rotation
    vectors at the system's rate; synthesis seed ``seed``) and ids."""
    f = HOME / f"{system}{'' if seed == 0 else f'_seed{seed}'}{TAG}.pkl"
    if f.exists():
        return pickle.loads(f.read_bytes())
    HOME.mkdir(parents=True, exist_ok=True)
    out = []
    for name, train, test, _ in make_folds(corpus(), "speakers", seed=0, speaker_folds=3):
        t = time.time()
        model = create(system, random_state=_sub_seed(0, name, system)).fit(train)
        fps = float(model.fps_)
        tr = [(np.asarray(model.predict(r.audio, seed=0).rotvec),
               np.asarray((r.motion if abs(r.motion.fps - fps) < 1e-9 else r.motion.resample(fps)).rotvec))
              for r in train]
        te = [(r.id, np.asarray(model.predict(r.audio, seed=seed).rotvec)) for r in test]
        out.append({"fps": fps, "train": tr, "test": te})
        print(f"{system} fold {name}: fitted and synthesised in {time.time() - t:.0f} s", flush=True)
    f.write_bytes(pickle.dumps(out))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--systems", default="tws-basic,tws-hier")
    ap.add_argument("--gains", default="0,1.2,2")
    ap.add_argument("--follow", type=float, default=speed_shaping.SHAPING_FOLLOW_S)
    ap.add_argument("--seed", type=int, default=0, help="synthesis seed of the held-out speech")
    ap.add_argument("--tag", default="", help="cache tag: the product settings the syntheses are made with")
    ap.add_argument("--adapt", type=float, default=speed_shaping.SHAPING_ADAPT_S,
                    help="the shaper's liveliness adaptation (s; 0 off; default the product's)")
    a = ap.parse_args()
    global TAG
    TAG = a.tag
    speed_shaping.SHAPING_ADAPT_S = a.adapt or None  # the template systems' shaper reads it when built
    recs = {r.id: r for r in corpus()}
    ctx: dict = {}
    for system in a.systems.split(","):
        folds = syntheses(system, a.seed)
        for g in (float(x) for x in a.gains.split(",")):
            t0 = time.time()
            refs, first = [], []
            for fd in folds:
                fps = fd["fps"]
                lag = speed_shaping.shaping_lag(fps)
                n = [min(len(x), len(y)) for x, y in fd["train"]]
                table = speed_shaping.speed_map([x[:k] for (x, _), k in zip(fd["train"], n)],
                                           [y[:k] for (_, y), k in zip(fd["train"], n)], lag=lag, max_gain=g) if g else None
                for rid, x in fd["test"]:
                    r = recs[rid]
                    y = x if table is None else speed_shaping.SpeedShaper(table, fps=fps, follow_s=a.follow, lag=lag).push(x)
                    refs.append(r)
                    first.append(at_rate(Motion(y, fps), r.motion.fps, len(r.motion)))
            s = rows_for(system, refs, first, ctx, n_shifts=100)[-1]
            sp_r = np.concatenate([R.speed(r.motion) for r in refs])
            sp_c = np.concatenate([R.speed(Motion(m, r.motion.fps)) for m, r in zip(first, refs)])
            print(f"{system} gain {g:g}: 1.5-4={s['band_1.5_4']:.3f} <0.5={s['band_0_0.5']:.2f} L1={s['spectral_l1']:.2f} "
                  f"SD={s['sd_ratio_pitch']:.2f}/{s['sd_ratio_yaw']:.2f}/{s['sd_ratio_roll']:.2f} "
                  f"Hpool={R.hellinger_values(sp_r, sp_c):.3f} LC={s['limit_cycle']:.2f} pause={s['pause_ratio']:.2f} "
                  f"FCCAx={s['fcca_excess']:+.3f} p={s['fcca_p_pooled']:.3f} ({time.time() - t0:.0f} s)", flush=True)
            qs = [5, 10, 25, 50, 75, 90, 95, 99]
            print("    speed quantiles °/s: recorded " + " ".join(f"{v:.1f}" for v in np.percentile(sp_r, qs))
                  + " | system " + " ".join(f"{v:.1f}" for v in np.percentile(sp_c, qs)), flush=True)


if __name__ == "__main__":
    main()
