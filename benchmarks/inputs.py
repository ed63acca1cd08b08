"""The benchmarks' inputs: where the shared speech is, and seeded speech of any length tiled from it
(used by ``run.py`` and ``serve_bench.py``)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("HEADMOTION_SHARED_DATA", ROOT.parent / "shared" / "data"))


def speech_dir() -> Path:
    d = SHARED / "speech"
    return d if d.is_dir() else ROOT / "examples" / "speech"


def speech_audio(seconds: float, seed: int = 0):
    from headmotion.synthetic import _speech_pool, speech_sources, tiled_speech
    from headmotion.types import Audio

    pool = _speech_pool(speech_sources(speech_dir()), 16000)
    return Audio(tiled_speech(pool, seconds, sample_rate=16000, rng=np.random.default_rng(seed)), 16000)
