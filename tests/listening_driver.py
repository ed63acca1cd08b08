"""``benchmarks/listening_load.py`` (the simulated participants of the listening-test server) as a
module for the tests that drive the server the same way (it is not part of the package)."""

from __future__ import annotations

from repo_scripts import load_script

driver = load_script("benchmarks/listening_load.py", "listening_load")
