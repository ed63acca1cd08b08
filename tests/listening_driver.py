"""``benchmarks/listening_load.py`` (the simulated participants of the listening-test server) as a
module for the tests that drive the server the same way (it is not part of the package)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _load():
    spec = importlib.util.spec_from_file_location("listening_load", ROOT / "benchmarks" / "listening_load.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


driver = _load()
