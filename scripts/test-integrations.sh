#!/usr/bin/env bash
# The voice-agent integrations' tests (tests/test_integration_pipecat.py,
# tests/test_integration_pipecat_browser.py and tests/test_integration_livekit.py), each framework
# in its own virtual environment with its framework at
# the version pinned in pyproject.toml's extras: Pipecat and LiveKit Agents want other releases of
# some packages than the main environment has, so neither is installed there (the main suite skips
# these two files).
#
#   bash scripts/test-integrations.sh [DIR]     # environments in DIR (default .venv-integrations/)
#
# Each environment: headmotion with the extra (editable; no PyTorch, which these tests do not need)
# and pytest; Pipecat's also its WebSocket transport (pipecat-ai[websocket]) and playwright for the
# browser test, which bundles Pipecat's browser client from npm (tests/pipecat_client: npm ci) and
# skips without Chromium (/usr/bin/chromium or HEADMOTION_CHROMIUM) or npm.  A second run reuses the
# environments and only checks the installs.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-.venv-integrations}
python=${PYTHON:-python}
status=0
for extra in pipecat livekit; do
  venv="$dir/$extra"
  if [ ! -x "$venv/bin/python" ]; then
    "$python" -m venv "$venv"
  fi
  case $extra in
    pipecat) dist=pipecat-ai; more=("pipecat-ai[websocket]==1.14.0" "playwright==1.65.2");
             tests=(tests/test_integration_pipecat.py tests/test_integration_pipecat_browser.py) ;;
    livekit) dist=livekit-agents; more=(); tests=(tests/test_integration_livekit.py) ;;
  esac
  "$venv/bin/python" -m pip install -q --disable-pip-version-check -e ".[$extra]" "pytest>=8" "${more[@]}"
  version=$("$venv/bin/python" -c 'import importlib.metadata as m, sys; print(m.version(sys.argv[1]))' "$dist")
  echo "== ${tests[*]} with $dist $version"
  "$venv/bin/python" -m pytest -q -p no:cacheprovider "${tests[@]}" || status=$?
done
exit "$status"
