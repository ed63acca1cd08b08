#!/usr/bin/env bash
# Install everything the full test suite needs on a fresh Debian machine with Python 3.11:
# CPU PyTorch first (so nothing pulls CUDA wheels), then the package with its extras, then the
# system packages for browser tests (Debian chromium) and rendering (EGL/Mesa software renderer).
set -euo pipefail
cd "$(dirname "$0")/.."
python -m pip install -q torch==2.13.0
python -m pip install -q -e ".[test,video]"  # the test extra includes ruff (lint in .ci/run)
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
