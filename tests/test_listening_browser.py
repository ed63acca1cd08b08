"""End to end in a real browser: a scripted participant completes each test type (MOS with
reference, MUSHRA, A/B) through the participant pages, and the stored answers equal what was
clicked.  Needs Debian's chromium (``apt-get install chromium``) and Playwright (Python)."""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

pytestmark = [pytest.mark.browser, pytest.mark.slow]

CHROMIUM = os.environ.get("HEADMOTION_CHROMIUM", "/usr/bin/chromium")
ADMIN = "admin-secret"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    def __init__(self, config: Path, db: Path):
        self.port = _free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "headmotion", "listen", "serve", str(config), "--port",
             str(self.port), "--database", f"sqlite:///{db}", "--admin-token", ADMIN],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.time() + 30
        while time.time() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"server died: {self.proc.stderr.read().decode()}")
            try:
                if httpx.get(self.url + "/api/test", timeout=1).status_code == 200:
                    return
            except httpx.HTTPError:
                time.sleep(0.1)
        raise RuntimeError("server did not start")

    def results(self) -> dict:
        return httpx.get(self.url + "/api/admin/results.json",
                         headers={"Authorization": f"Bearer {ADMIN}"}).json()

    def stop(self):
        self.proc.terminate()
        self.proc.wait(10)


@pytest.fixture(scope="module")
def browser():
    if not Path(CHROMIUM).exists():
        pytest.skip(f"chromium not installed at {CHROMIUM} (apt-get install chromium)")
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as pw:
        b = pw.chromium.launch(executable_path=CHROMIUM, headless=True, args=[
            "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--headless",
            "--autoplay-policy=no-user-gesture-required"])
        yield b
        b.close()


def _example(tmp_path: Path, examples_dir: Path, name: str) -> Path:
    shutil.copytree(examples_dir / "listening", tmp_path / "test",
                    ignore=shutil.ignore_patterns("results"))
    return tmp_path / "test" / name


def _consent_and_demographics(page, demo: dict | None):
    page.check("#consent-box")
    page.click("#consent")
    if demo is not None:
        page.wait_for_selector("#demographics")
        for k, v in demo.items():
            page.select_option(f"#q-{k}", v)
        page.click("#demo-submit")
    page.wait_for_selector("#start")
    page.click("#start")


def _wait_js(page, expr: str, timeout: float = 30000) -> None:
    """Wait until ``expr`` is true.  Polls with ``page.evaluate`` (run through the DevTools
    protocol): ``page.wait_for_function`` evals a string inside the page, which the server's
    Content-Security-Policy (no 'unsafe-eval') rightly refuses."""
    import time as _time

    end = _time.monotonic() + timeout / 1000
    while True:
        if page.evaluate(f"Boolean({expr})"):
            return
        if _time.monotonic() > end:
            raise TimeoutError(f"timed out waiting for {expr}")
        page.wait_for_timeout(50)


def _wait_trial(page, index: int):
    _wait_js(page, 
        f"document.querySelector('#main').dataset.trial === '{index}' || "
        "document.body.dataset.stage === 'done'")


SMALL_MOS = """type: mos_ref
name: small-mos
seed: 5
demographics:
  - {name: native_language, label: "Native English speaker?", options: ["yes", "no"]}
  - {name: listening, label: "Headphones or speakers?", options: [headphones, speakers]}
  - {name: gender, label: Gender, options: [female, male, other]}
training:
  - id: train
    speaker: A
    reference: {motion: motion/s1_natural.npz, audio: audio/s1.wav}
    conditions: {system: {motion: motion/s1_system.npz, audio: audio/s1.wav}}
items:
""" + "".join(f"""  - id: {s}
    speaker: {spk}
    reference: {{motion: motion/{s}_natural.npz, audio: audio/{s}.wav}}
    conditions:
      natural: {{motion: motion/{s}_natural.npz, audio: audio/{s}.wav}}
      noise: {{motion: motion/{s}_noise.npz, audio: audio/{s}.wav}}
""" for s, spk in (("s2", "A"), ("s3", "B"))) + """attention_checks:
  - {after: 2, question: "Please choose blue.", options: [red, blue, green], answer: blue}
"""


def test_mos_ref_participant_in_browser(browser, tmp_path, examples_dir):
    # the example stimuli (motion + audio, drawn by the viewer component), fewer trials
    _example(tmp_path, examples_dir, "config.yaml")
    cfg = tmp_path / "test" / "small.yaml"
    cfg.write_text(SMALL_MOS)
    srv = Server(cfg, tmp_path / "mos.sqlite")
    try:
        ctx = browser.new_context()
        page = ctx.new_page()
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(srv.url + "/")
        demo = {"native_language": "no", "listening": "headphones", "gender": "female"}
        _consent_and_demographics(page, demo)
        clicked = {}
        n = page.evaluate("window.__listen.info.n_trials")
        for i in range(n):
            _wait_trial(page, i)
            if i == 3:  # close the tab and come back: resumes at the same trial
                page.close()
                page = ctx.new_page()
                page.goto(srv.url + "/")
                _wait_trial(page, i)
            assert page.inner_text("#progress-text") == f"{i + 1} of {n}"
            if page.query_selector("#attention"):
                page.click("[data-option='blue']")
                clicked[i] = "blue"
            else:
                if i == 0:
                    assert page.inner_text("#phase") == "Training"
                    # motion + audio stimuli are drawn by the project's viewer component
                    _wait_js(page, 
                        "document.querySelectorAll('.player[data-viewer=ready]').length === 2",
                        timeout=20000)
                    page.click("[data-play='Video']")
                    _wait_js(page, 
                        "document.querySelector('[data-slot=Video] .player')"
                        ".headmotionViewer.getState().time > 0.2", timeout=20000)
                    page.click("[data-play='Video']")  # replay restarts from the beginning
                    t = page.evaluate("document.querySelector('[data-slot=Video] .player')"
                                      ".headmotionViewer.getState().time")
                    assert t < 0.5
                r = 1 + (i * 3) % 7
                page.click(f"#rating-{r}")
                clicked[i] = float(r)
            page.click("#submit")
        page.wait_for_selector("#done")
        assert not errors, errors
        res = srv.results()
        ans = res["answers"]
        assert len(ans) == n
        got = {a["trial_index"]: (a["condition"] if a["kind"] == "attention" else a["value"])
               for a in ans}
        assert got == clicked
        assert [a["phase"] for a in ans] == ["training", "test", "test", "attention", "test",
                                              "test"]
        assert ans[0]["demo_gender"] == "female"
        # no going back: the page holds no back button and the server refuses a changed rating
        assert res["participants"][0]["stage"] == "done"
    finally:
        srv.stop()


def _make_mp4(path: Path, color: str):
    import imageio_ffmpeg

    subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-y", "-f", "lavfi",
                    "-i", f"color=c={color}:s=64x48:d=1:r=10", "-pix_fmt", "yuv420p", str(path)],
                   check=True)


def test_mushra_participant_in_browser_with_mp4(browser, tmp_path):
    d = tmp_path / "mushra"
    d.mkdir()
    conds = {"reference": "white", "sys": "gray", "anchor": "black"}
    for c, col in conds.items():
        _make_mp4(d / f"{c}.mp4", col)
    items = "\n".join(
        f"  - id: item{k}\n    speaker: {'AB'[k % 2]}\n    reference: reference.mp4\n"
        f"    conditions:\n" + "".join(f"      {c}: {c}.mp4\n" for c in conds) for k in range(3))
    (d / "t.yaml").write_text(f"type: mushra\nname: m\nrequire_play: true\n"
                              f"mushra: {{anchor: anchor}}\nitems:\n{items}")
    srv = Server(d / "t.yaml", tmp_path / "m.sqlite")
    try:
        page = browser.new_page()
        page.goto(srv.url + "/")
        _consent_and_demographics(page, None)
        set_values = {}
        for i in range(3):
            _wait_trial(page, i)
            labels = page.eval_on_selector_all(".stim[data-slot]:not([data-slot=Reference])",
                                               "els => els.map(e => e.dataset.slot)")
            assert sorted(labels) == ["A", "B", "C"]
            page.click("[data-play='Reference']")
            for j, lab in enumerate(labels):
                v = 10 + 37 * j + i
                page.fill(f"#slider-{lab}", str(v))
                page.click(f"[data-play='{lab}']")
                set_values[(i, lab)] = float(v)
            assert page.is_enabled("#submit")
            page.click("#submit")
        page.wait_for_selector("#done")
        ans = srv.results()["answers"]
        assert {(a["trial_index"], a["slot"]): a["value"] for a in ans} == set_values
        assert {a["condition"] for a in ans} == set(conds)
    finally:
        srv.stop()


def test_ab_participant_in_browser(browser, tmp_path):
    d = tmp_path / "ab"
    d.mkdir()
    conds = {"natural": "white", "system": "gray", "desync": "black"}
    for c, col in conds.items():
        _make_mp4(d / f"{c}.mp4", col)
    items = "".join(f"  - id: item{k}\n    conditions:\n" +
                    "".join(f"      {c}: {c}.mp4\n" for c in conds) for k in range(2))
    (d / "t.yaml").write_text(f"type: ab\nname: ab\nitems:\n{items}")
    srv = Server(d / "t.yaml", tmp_path / "ab.sqlite")
    try:
        page = browser.new_page()
        page.goto(srv.url + "/")
        _consent_and_demographics(page, None)
        n = page.evaluate("window.__listen.info.n_trials")
        assert n == 6
        clicked = {}
        for i in range(n):
            _wait_trial(page, i)
            side = "left" if i % 3 else "right"
            page.click(f"[data-play='{side.title()}']")
            page.click(f"#choose-{side}")
            clicked[i] = side
            page.click("#submit")
        page.wait_for_selector("#done")
        ans = srv.results()["answers"]
        assert {a["trial_index"]: a["slot"] for a in ans} == clicked
        # each pair (2 trials per participant) once on each side
        left = {}
        for a in ans:
            ls = a["condition"] if a["slot"] == "left" else a["other"]
            key = tuple(sorted((a["condition"], a["other"])))
            left.setdefault(key, []).append(ls == key[0])
        assert len(left) == 3
        for key, v in left.items():
            assert sum(v) * 2 == len(v), (key, v)
    finally:
        srv.stop()
