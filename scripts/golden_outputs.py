"""Fingerprints of what every system and both shipped models synthesise, to show that a change to the
code's structure changes no output (bit for bit).

Every registered system is trained with small settings on a seeded planted corpus; each, and the
shipped ``default`` and ``stream``, synthesises a fixed clip with several seeds, with gain and
offset, as two samples, and — where it streams — in uneven chunks.  Each output's SHA-256 (of its
float64 rotation vectors and its rate) goes into a JSON file; ``--compare`` prints what differs.

    python scripts/golden_outputs.py -o before.json            # before the change
    python scripts/golden_outputs.py -o after.json --compare before.json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from test_contract import TINY as CONTRACT_TINY  # noqa: E402  (the contract tests' small settings)

#: every registered system with the contract tests' small settings, motion-match on both prosodies
#: and live
TINY = {**CONTRACT_TINY, "motion-match": dict(prosody="f0e-live"), "motion-match-f0e": CONTRACT_TINY["motion-match"],
        "motion-match-live": dict(live=True, hop=4)}


def digest(motion) -> str:
    rv = np.ascontiguousarray(np.asarray(motion.rotvec, dtype=np.float64))
    return hashlib.sha256(rv.tobytes() + repr(float(motion.fps)).encode()).hexdigest()[:16]


def streamed(model, audio, seed: int) -> str:
    from headmotion.synthesis import open_stream
    from headmotion.types import Motion

    s = open_stream(model, seed=seed, sample_rate=audio.sample_rate)
    x = audio.samples.astype(np.float32)
    parts, i, k = [], 0, 0
    while i < len(x):
        n = (160, 1234, 4000)[k % 3]
        parts.append(s.push(x[i:i + n]))
        i, k = i + n, k + 1
    parts.append(s.flush())
    rv = np.vstack([np.asarray(p.rotvec).reshape(-1, 3) for p in parts])
    return digest(Motion(rv, parts[-1].fps))


def fingerprints(model, audio) -> dict:
    from headmotion.synthesis import synthesize

    out = {}
    for seed in (0, 3):
        out[f"seed{seed}"] = digest(synthesize(audio, model, seed=seed)[0])
    out["gain_offset"] = digest(synthesize(audio, model, seed=1, gain="1.3,0.5,1", offset_degrees="2,0,-3")[0])
    out["samples2"] = [digest(m) for m in synthesize(audio, model, seed=5, samples=2)]
    out["predict_gain"] = digest(synthesize(audio, model, seed=2, gain=0.7, offset=(0.01, 0.0, 0.0))[0])
    if getattr(model, "can_stream", False):
        out["stream"] = streamed(model, audio, 4)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", type=Path, required=True)
    ap.add_argument("--compare", type=Path, default=None, help="an earlier output: print what differs")
    ap.add_argument("--only", default=None, help="comma-separated names (systems, default, stream)")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    from headmotion.synthesis import load_model
    from headmotion.synthetic import planted_corpus
    from headmotion.systems import create

    corpus = planted_corpus(minutes=1.5, n_recordings=3, seed=11)
    audio = corpus[2].audio.slice_seconds(0, 6.0)
    only = set(args.only.split(",")) if args.only else None
    result = {}
    for name in ("default", "stream"):
        if only is None or name in only:
            result[name] = fingerprints(load_model(name), audio)
            print(name, flush=True)
    for name, params in TINY.items():
        if only is not None and name not in only:
            continue
        system = "motion-match" if name.startswith("motion-match") else name
        model = create(system, **params).fit(corpus)
        result[name] = fingerprints(model, audio)
        print(name, flush=True)
    args.output.write_text(json.dumps(result, indent=1, sort_keys=True))
    if args.compare is None:
        return 0
    before = json.loads(args.compare.read_text())
    diff = [(k, c) for k in sorted(set(before) | set(result)) for c in sorted(set(before.get(k, {})) | set(result.get(k, {})))
            if before.get(k, {}).get(c) != result.get(k, {}).get(c)]
    for k, c in diff:
        print(f"differs: {k} {c}")
    print("identical" if not diff else f"{len(diff)} outputs differ")
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main())
