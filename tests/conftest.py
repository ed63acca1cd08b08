"""Shared fixtures.

``shared_data`` points at ``../shared/data`` (the real third-party files); tests that use it skip
with a reason when it is absent, so the suite runs on any machine.  ``examples_dir`` holds the
project's own small files, which are always present.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

# Synthesis runs the networks with the model's n_threads BLAS threads (1 by default), and float32
# matrix products round differently with more threads: the tests' reference computations run
# with the same single BLAS thread, whatever the machine's default.
_BLAS_THREADS = threadpool_limits(limits=1, user_api="blas")

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("HEADMOTION_SHARED_DATA", ROOT.parent / "shared" / "data"))
EXAMPLES = ROOT / "examples"
#: model files written by earlier versions (tests/data/models/README.md)
OLD_MODELS = Path(__file__).resolve().parent / "data" / "models"
#: the former shipped default (mfcc-dnn) and streaming model (tws-hier, 100 fps, causal)
OLD_DNN_MODEL = OLD_MODELS / "mfcc-dnn_video.hmz"
OLD_TWS_MODEL = OLD_MODELS / "tws-hier_video.hmz"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real data not available: {SHARED_DATA} is absent")
    return SHARED_DATA


@pytest.fixture(scope="session")
def examples_dir() -> Path:
    return EXAMPLES


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture
def torch_one_thread():
    """Tiny tensors: one intra-op torch thread avoids OpenMP overhead on a busy machine."""
    import torch

    prev = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(prev)


@pytest.fixture(scope="session")
def planted():
    """``planted(**kwargs)``: :func:`headmotion.synthetic.planted_corpus`, built once per session
    for each set of arguments (corpora are read-only, so tests share them)."""
    from headmotion.synthetic import planted_corpus

    cache: dict = {}

    def make(**kwargs):
        key = tuple(sorted((k, tuple(v) if isinstance(v, list) else v) for k, v in kwargs.items()))
        if key not in cache:
            cache[key] = planted_corpus(**kwargs)
        return cache[key]

    return make


@pytest.fixture(scope="module")
def gl():
    """Offscreen OpenGL is available (the rendering tests skip with the reason otherwise)."""
    from headmotion.errors import MissingDependencyError
    from headmotion.render.offscreen import create_context

    try:
        ctx = create_context()
    except MissingDependencyError as exc:
        pytest.skip(f"no offscreen OpenGL: {exc}")
    ctx.release()
    return True


#: the Chromium the browser tests drive (Debian's package by default)
CHROMIUM = os.environ.get("HEADMOTION_CHROMIUM", "/usr/bin/chromium")


@pytest.fixture
def playwright():
    """``sync_playwright``, or a skip with the reason (no playwright, no Chromium)."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("playwright is not installed")
    if not (Path(CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        pytest.skip(f"chromium not found at {CHROMIUM}")
    return sync_playwright
