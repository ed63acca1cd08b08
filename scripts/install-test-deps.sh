#!/usr/bin/env bash
# Install everything the full test suite needs on a fresh Debian machine with Python 3.11, into the
# Python environment that runs it (a virtual environment: .ci/run makes a fresh one):
# CPU PyTorch first (the test extra's nets, for the network systems' tests; pinned so that nothing
# pulls CUDA wheels), then the package with its test and video extras, then — as root, with apt —
# the system packages for browser tests (Debian chromium), rendering (EGL/Mesa software renderer),
# the glTF import test (Blender) and the PostgreSQL tests.  About 20 minutes on a fresh machine.
#
#   TORCH_INDEX_URL=https://download.pytorch.org/whl/cpu bash scripts/install-test-deps.sh
#
# on a plain package index, where torch==2.13.0 for Linux is the CUDA build.
set -euo pipefail
cd "$(dirname "$0")/.."
torch_index=${TORCH_INDEX_URL:-}
python -m pip install -q torch==2.13.0 ${torch_index:+--index-url "$torch_index"}
python -m pip install -q -e ".[test,video]"  # the test extra includes ruff and import-linter (.ci/run)
if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
  need=()
  for pkg in chromium libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri blender postgresql; do
    dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
  done
  if [ ${#need[@]} -gt 0 ]; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
  fi
fi
