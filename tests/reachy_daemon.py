"""The Reachy Mini SDK's daemon for tests/test_integration_reachy.py: its mock-up simulation (no
robot, no MuJoCo: targets become the pose at once, its kinematics report the pose) on a free
port of this machine, without media, and kept to this machine — no telemetry, no dataset
downloads, no hub calls, and (run as ``python tests/reachy_daemon.py ARGS``) no mDNS
advertisement, which the daemon otherwise multicasts on every network interface.

:func:`start` launches it and waits until it reports ``running``; :func:`stop` ends it."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _running(port: int) -> bool:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/daemon/status", timeout=1.0) as r:
            return json.load(r).get("state") == "running"
    except (OSError, ValueError):
        return False


def start(port: int, home: Path, *, timeout_s: float = 90.0) -> subprocess.Popen:
    """The daemon on ``port`` (its files under ``home``), once it runs; its output in ``home/daemon.log``."""
    home.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "REACHY_MINI_TELEMETRY": "0", "DO_NOT_TRACK": "1", "HF_HUB_OFFLINE": "1",
           "HF_HUB_DISABLE_TELEMETRY": "1", "XDG_CONFIG_HOME": str(home / "config"),
           "XDG_CACHE_HOME": str(home / "cache"), "XDG_DATA_HOME": str(home / "data")}
    log = open(home / "daemon.log", "wb")  # noqa: SIM115 - the daemon writes it while it runs
    proc = subprocess.Popen(
        [sys.executable, __file__, "--mockup-sim", "--headless", "--no-media", "--fastapi-host", "127.0.0.1",
         "--fastapi-port", str(port), "--dataset-update-interval", "0", "--no-preload-datasets",
         "--no-goto-sleep-on-stop", "--log-level", "WARNING"],
        stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    log.close()
    deadline = time.monotonic() + timeout_s
    while not _running(port):
        if proc.poll() is not None or time.monotonic() > deadline:
            stop(proc)
            raise RuntimeError(f"the Reachy Mini daemon did not start on port {port}: "
                               + (home / "daemon.log").read_text(errors="replace")[-2000:])
        time.sleep(0.3)
    return proc


def stop(proc: subprocess.Popen, *, kill: bool = False) -> None:
    """End the daemon (``kill``: at once, as a crash would)."""
    if proc.poll() is not None:
        return
    os.killpg(proc.pid, signal.SIGKILL if kill else signal.SIGTERM)
    try:
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)


if __name__ == "__main__":  # the daemon itself, without its mDNS advertisement
    from reachy_mini.daemon.app.main import main
    from reachy_mini.utils import discovery

    def _no_mdns(_self) -> None:
        return None

    discovery.MdnsServiceRegistration.register = _no_mdns
    discovery.MdnsServiceRegistration.unregister = _no_mdns
    sys.argv[0] = "reachy-mini-daemon"
    sys.exit(main())
