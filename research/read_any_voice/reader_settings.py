#!/usr/bin/env python
"""Choosing how Praat reads the f0e-live prosody (docs/decisions/read-any-voice.md): the held-out-source
coupling of ``motion-match`` variants whose Praat settings (:data:`headmotion.systems.motion_match.library.PRAAT_LIVE`,
``PRAAT_OFFLINE``) are replaced for the run, next to the same variants as ``scripts/source_holdout_choice.py``
runs them.

    python research/read_any_voice/reader_settings.py ~/.cache/headmotion/corpus/talking_video \\
        --held sadtalker+styletalk --seeds 0-3 --variants '{"live-0.5": [{"live": true, "hop": 2, "reader": "praat"},
        {"praat_back_s": 0.5}]}'

Each variant is ``[motion-match parameters, Praat settings merged over the shipped ones]``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def main(argv=None) -> int:
    import headmotion.systems.motion_match.estimator as est

    sys.path.insert(0, str(ROOT / "scripts"))
    import source_holdout_choice as choice

    argv = list(sys.argv[1:] if argv is None else argv)
    i = argv.index("--variants")
    variants = json.loads(argv[i + 1])
    base_live, base_off = dict(est.PRAAT_LIVE), dict(est.PRAAT_OFFLINE)
    for name, (params, praat) in variants.items():
        est.PRAAT_LIVE = {**base_live, **praat}
        est.PRAAT_OFFLINE = {**base_off, **praat}
        argv[i + 1] = json.dumps({name: params})
        choice.main(argv)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
