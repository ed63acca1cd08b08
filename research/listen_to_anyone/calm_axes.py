"""How much of the waiting head's own movement the listening head calms, per axis
(``headmotion.listener.head.CALM``: pitch, yaw, roll; docs/decisions/listen-to-anyone.md).

The listening ruler (``headmotion evaluate-listening``'s measures: nods read from the output motion,
cues read by Praat, hits against circularly shifted nods) on one set of conversations, for each
variant of CALM given as ``NAME=P,Y,R`` (``NAME=P,Y,R@TAU`` sets the slow course's time constant
``CALM_TAU_S`` too); one line per variant, voices and condition: nods per minute
of heard speech, the share of nods after a cue against the shifted nods', p per seed, and the head's
speed in the other's turns (°/s).

    python research/listen_to_anyone/calm_axes.py --corpus ~/.cache/headmotion/corpus/talking_video \\
        --shared ../shared/data --set choice -m default --seeds 1-3 now=0.8,0.8,0.8 pitch=0.95,0.6,0.6 tau3=0.8,0,0@3
"""

from __future__ import annotations

import argparse
from pathlib import Path


def main(argv=None) -> int:
    from headmotion.cli.speech_eval_cmds import parse_seeds
    from headmotion.evaluation.protocol.conversations import build_conversations
    from headmotion.evaluation.protocol.listening import group_rows, run_conversation
    from headmotion.listener import head
    from headmotion.synthesis import load_model

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("variants", nargs="+", help="NAME=PITCH,YAW,ROLL[@TAU] (shares of the movement calmed; "
                    "the slow course's time constant in seconds)")
    ap.add_argument("--corpus", type=Path)
    ap.add_argument("--shared", type=Path)
    ap.add_argument("--set", default="choice")
    ap.add_argument("-m", "--model", default="default")
    ap.add_argument("--seeds", default="1-3")
    ap.add_argument("--degrade", default="clean,noise20,telephone")
    a = ap.parse_args(argv)
    convs, missing = build_conversations(a.set, corpus=a.corpus, shared=a.shared,
                                         conditions=tuple(a.degrade.split(",")))
    for line in missing:
        print("missing:", line)
    model, seeds = load_model(a.model), parse_seeds(a.seeds)
    print("| variant | voices | condition | nods/min | hits vs shifted | p per seed | speed °/s |")
    print("|---|---|---|---|---|---|---|")
    tau0 = head.CALM_TAU_S
    for spec in a.variants:
        name, values = spec.split("=")
        values, _, tau = values.partition("@")
        head.CALM = tuple(float(v) for v in values.split(","))
        head.CALM_TAU_S = float(tau) if tau else tau0
        runs = [run_conversation(c, model, seeds=seeds, levels=False) for c in convs]
        for r in group_rows(runs):
            res = r.result
            p = " / ".join(f"{x:.3f}" for x in res.p)
            print(f"| {name} | {r.voices} | {r.condition} | {r.nods_per_min:.1f} | "
                  f"{sum(res.share) / len(res.share):.2f} vs {sum(res.shifted) / len(res.shifted):.2f} | {p} | "
                  f"{sum(r.speed) / len(r.speed):.1f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
