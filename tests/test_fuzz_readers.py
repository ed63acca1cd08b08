"""Property-based fuzzing of every reader.

hypothesis picks a format, a mutation class (truncation, bit flips, numbers replaced by
nan/inf/0/−1/1e9/1e-320/1e308/a 5000-digit integer, header fields, duplicated or deleted lines, a
huge field, deep JSON nesting) and a seed; ``scripts/fuzz.py`` makes the mutated file from a small
real-style seed and reads it in a worker process with a 2 GiB address-space limit and a time limit
(a hang or an out-of-memory counts as a crash).  The only outcomes allowed are a valid motion /
audio / model, or a :class:`~headmotion.errors.HeadMotionError` naming the file — for the library
call and for ``headmotion info``.  Every input that ever crashed is kept under
``tests/data/fuzz/crashes/<format>/`` and replayed here on every run.

This part of the suite is sized to stay under a minute; ``python scripts/fuzz.py --minutes N``
runs deeper.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from repo_scripts import load_script  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CORPUS = ROOT / "tests" / "data" / "fuzz" / "crashes"


fuzz = load_script("scripts/fuzz.py", "headmotion_fuzz")
MINE = [f for f in fuzz.FORMATS if f != "openface"]
PAIRS = [(f, c) for f in MINE for c in fuzz.classes_for(f)]


@pytest.fixture(scope="module")
def worker():
    import os

    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT / "src") + os.pathsep + env.get("PYTHONPATH", "")
    w = fuzz.Worker(mem_mb=2048, timeout=30.0, env=env)
    yield w
    w.close()


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz_seeds")
    return {f: fuzz.make_seed(f, d) for f in fuzz.FORMATS}, tmp_path_factory.mktemp("fuzz_inputs")


def _check(worker, fmt, path):
    res = worker.run(fmt, str(path))
    assert res["outcome"] in ("valid", "error"), f"{fmt} {path.name}: {res}"
    return res


def test_seeds_are_valid(worker, seeds):
    files, _ = seeds
    for fmt, p in files.items():
        assert worker.run(fmt, str(p))["outcome"] == "valid", fmt


def _mutated(seeds, fmt, cls, seed):
    files, out = seeds
    data = fuzz.mutate(fmt, files[fmt], cls, random.Random(seed))
    path = out / f"input{fuzz.FORMATS[fmt]}"
    path.write_bytes(data)
    return path


@settings(max_examples=120, deadline=None, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(pair=st.sampled_from(PAIRS), seed=st.integers(0, 2**32 - 1))
def test_mutated_files_give_valid_motion_or_a_clear_error(worker, seeds, pair, seed):
    fmt, cls = pair
    _check(worker, fmt, _mutated(seeds, fmt, cls, seed))


@settings(max_examples=15, deadline=None, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(cls=st.sampled_from(fuzz.classes_for("openface")), seed=st.integers(0, 2**32 - 1))
def test_openface_reader_under_mutation(worker, seeds, cls, seed):
    _check(worker, "openface", _mutated(seeds, "openface", cls, seed))


def _corpus():
    if not CORPUS.is_dir():
        return []
    return sorted(p for p in CORPUS.rglob("*") if p.is_file() and p.parent.name in fuzz.FORMATS)


@pytest.mark.parametrize("path", _corpus(), ids=lambda p: f"{p.parent.name}/{p.name}")
def test_crash_corpus_replays_clean(worker, path, tmp_path):
    """Every input that crashed a reader once (in earlier versions or in a deep run) stays fixed."""
    _check(worker, path.parent.name, fuzz.corpus_file(path, tmp_path))


def test_crash_corpus_is_not_empty():
    assert len(_corpus()) >= 20
