"""Adapting on one half of a take and synthesising on the other: detectability (6-s groups),
four takes' pairwise correlation, SD beside the recorded (docs/decisions/amount-and-adapt.md).

    python scripts/adapt_halves.py CORPUS BASE_COSTS [AMOUNT] [REPEAT_COST]
    python scripts/adapt_halves.py .zeggs_corpus 2      # a negative cost: the default, not adapted
"""
import sys, time, numpy as np, itertools
from headmotion.corpus import Corpus
from headmotion.evaluation.protocol.pause_folds import split_corpus_at_pauses
from headmotion.evaluation.detection.detectability import detectability
from headmotion.systems.adapt import adapt
from headmotion.synthesis import load_model
c = Corpus.load(sys.argv[1] if len(sys.argv) > 1 else '.zeggs_corpus')
halves, _ = split_corpus_at_pauses(c, 2)
print([(r.id, round(r.duration, 1)) for r in halves])
costs = [float(x) for x in (sys.argv[2] if len(sys.argv) > 2 else "2").split(",")]
amount = float(sys.argv[3]) if len(sys.argv) > 3 else 1.0
for cost in costs:
    for i in (0, 1):
        train, test = halves.subset([1 - i]), halves[i]
        t = time.time()
        if cost < 0:
            m = load_model("default")
        else:
            m = adapt(train, "default", base_cost=cost, min_speech_s=10)
        dt = time.time() - t
        m.set_params(amount=amount, repeat_cost=float(sys.argv[4]) if len(sys.argv) > 4 else m.repeat_cost)
        gens = [m.predict(test.audio, seed=s) for s in range(4)]
        d = detectability({test.id: test.motion}, {test.id: gens}, chunk_s=6.0, seed=0, classifiers=("stats",), n_boot=200)
        X = [np.degrees(g.rotvec) for g in gens]
        corr = [np.mean([np.corrcoef(a[:, k], b[:, k])[0, 1] for k in range(3)]) for a, b in itertools.combinations(X, 2)]
        own = (m._own.mean() if hasattr(m, "_own") else 0)
        print(f"cost {cost} half {i}: adapt {dt:.1f}s detect {d.detectability:.2f} pair corr max {max(corr):.2f} mean {np.mean(corr):.2f} "
              f"SD gen {np.mean([x.std(0) for x in X], 0).round(1)} rec {np.degrees(test.motion.rotvec).std(0).round(1)}", flush=True)
