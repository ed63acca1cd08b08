#!/usr/bin/env bash
# The integrations' tests (tests/test_integration_pipecat.py,
# tests/test_integration_pipecat_browser.py, tests/test_integration_livekit.py and
# tests/test_integration_reachy.py), each framework in its own virtual environment with its
# framework at the version pinned in pyproject.toml's extras: Pipecat, LiveKit Agents and the
# Reachy Mini SDK want other releases of some packages than the main environment has (the SDK:
# websockets < 16), so none is installed there (the main suite skips these files).
#
#   bash scripts/test-integrations.sh [DIR]     # environments in DIR (default .venv-integrations/)
#
# Each environment: headmotion with the extra (editable; no PyTorch, which these tests do not need)
# and pytest; Pipecat's also its WebSocket transport (pipecat-ai[websocket]) and playwright for the
# browser test, which bundles Pipecat's browser client from npm (tests/pipecat_client: npm ci) and
# skips without Chromium (/usr/bin/chromium or HEADMOTION_CHROMIUM) or npm.  The Reachy Mini SDK
# (reachy-mini) builds PyGObject and pycairo, which need Debian's GObject-introspection and cairo
# headers and its GStreamer typelibs: as root, with apt, they are installed here; without them the
# Reachy environment is skipped with a message (its tests run the SDK's own daemon, mock-up
# simulation, on a free local port: tests/reachy_daemon.py).  A second run reuses the environments
# and only checks the installs.
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-.venv-integrations}
python=${PYTHON:-python}
status=0
reachy_apt=(libcairo2-dev libgirepository1.0-dev gir1.2-gst-plugins-base-1.0 gir1.2-gst-plugins-bad-1.0)
if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
  need=()
  for pkg in "${reachy_apt[@]}"; do
    dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
  done
  if [ ${#need[@]} -gt 0 ]; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
  fi
fi
for extra in pipecat livekit reachy; do
  venv="$dir/$extra"
  if [ "$extra" = reachy ] && ! pkg-config --exists gobject-introspection-1.0 cairo 2>/dev/null; then
    echo "== skipping tests/test_integration_reachy.py: the Reachy Mini SDK needs ${reachy_apt[*]} (apt, as root)"
    continue
  fi
  if [ ! -x "$venv/bin/python" ]; then
    "$python" -m venv "$venv"
  fi
  case $extra in
    pipecat) dist=pipecat-ai; more=("pipecat-ai[websocket]==1.14.0" "playwright==1.65.2");
             tests=(tests/test_integration_pipecat.py tests/test_integration_pipecat_browser.py) ;;
    livekit) dist=livekit-agents; more=(); tests=(tests/test_integration_livekit.py) ;;
    reachy) dist=reachy-mini; more=(); tests=(tests/test_integration_reachy.py) ;;
  esac
  "$venv/bin/python" -m pip install -q --disable-pip-version-check -e ".[$extra]" "pytest>=8" "${more[@]}"
  version=$("$venv/bin/python" -c 'import importlib.metadata as m, sys; print(m.version(sys.argv[1]))' "$dist")
  echo "== ${tests[*]} with $dist $version"
  "$venv/bin/python" -m pytest -q -p no:cacheprovider "${tests[@]}" || status=$?
done
exit "$status"
