"""The local viewer server behind ``headmotion view MOTION... [--audio A]``.

A small FastAPI app (the framework the listening tests use too) served by uvicorn on localhost:

* ``/``                  — the page (body ``static/index.body.html``, :mod:`headmotion.serve.pages`)
  that mounts the viewer component;
* ``/api/session``       — ``{motions: [{label, url}], audioUrl, mask, style}`` for the page;
* ``/motion/{i}.json``   — one motion as ``{fps, rotvec, translation?}`` (:func:`motion_payload`);
* ``/audio.wav``         — the speech as 16-bit WAV (served as a file, so HTTP range requests and
  hence seeking work in every browser);
* ``/viewer/...``        — the static files: ``viewer.js`` (three.js bundled), ``head_mesh.bin`` and
  the page's stylesheet.

Libraries considered: ``http.server`` (no range requests for audio seeking, which Chromium needs),
Flask (not otherwise used in the project); FastAPI/Starlette's ``FileResponse`` handles ranges.
"""

from __future__ import annotations

import contextlib
import os
import socket
import tempfile
import threading
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..types import Audio, Motion

STATIC = Path(__file__).resolve().parent / "static"


def motion_payload(motion: Motion, *, label: str | None = None, decimals: int = 6) -> dict:
    """A motion as the JSON the viewer component reads: ``{"fps", "rotvec": [[x, y, z], ...]}``
    (radians, ``(T, 3)``) plus ``"translation"`` (metres, about the clip's mean position) when
    present and ``"label"``."""
    d = {"fps": float(motion.fps), "rotvec": np.round(motion.rotvec, decimals).tolist()}
    if motion.translation is not None:  # about the clip's mean position (as in the videos)
        tr = motion.translation - motion.translation.mean(axis=0)
        d["translation"] = np.round(tr, decimals).tolist()
    if label is not None:
        d["label"] = str(label)
    return d


def _write_wav(audio, tmpdir: str) -> str | None:
    if audio is None:
        return None
    if not isinstance(audio, Audio):
        from ..io import load_audio

        audio = load_audio(audio)
    import soundfile as sf

    path = os.path.join(tmpdir, "audio.wav")
    sf.write(path, np.clip(audio.samples, -1, 1), audio.sample_rate, subtype="PCM_16")
    return path


def page_app(name: str, title: str):
    """A FastAPI app titled ``headmotion TITLE`` (no API docs) whose ``/`` is the page ``name``
    (:func:`headmotion.serve.pages.page_html`) and which serves ``static/`` under ``/viewer``: the
    viewer's and the live view's."""
    from fastapi import FastAPI
    from fastapi.staticfiles import StaticFiles

    from ..serve.pages import page_response

    app = FastAPI(title=f"headmotion {title}", docs_url=None, redoc_url=None, openapi_url=None)

    @app.get("/")
    def index():
        return page_response(name, title, static="/viewer")

    app.mount("/viewer", StaticFiles(directory=STATIC), name="viewer")
    return app


def create_app(motions, *, labels=None, audio_path: str | None = None, mask: bool = True,
               style: str = "textured"):
    """The FastAPI app for a list of motions (audio already written as a WAV file, or None)."""
    from fastapi import HTTPException
    from fastapi.responses import FileResponse, JSONResponse

    ms = [motions] if isinstance(motions, Motion) else list(motions)
    if not ms:
        raise ParameterError("the viewer needs at least one motion")
    labels = [f"motion {i + 1}" for i in range(len(ms))] if labels is None else [str(s) for s in labels]
    if len(labels) != len(ms):
        raise ParameterError(f"{len(labels)} labels given for {len(ms)} motions")
    if style not in ("textured", "smooth", "silhouette"):
        raise ParameterError(f"style must be textured, smooth or silhouette; got {style!r}")
    payloads = [motion_payload(m, label=lab) for m, lab in zip(ms, labels)]
    app = page_app("index", "viewer")

    @app.get("/api/session")
    def session():
        return {
            "motions": [{"label": lab, "url": f"/motion/{i}.json"} for i, lab in enumerate(labels)],
            "audioUrl": "/audio.wav" if audio_path else None,
            "mask": mask, "style": style,
        }

    @app.get("/motion/{i}.json")
    def motion(i: int):
        if not 0 <= i < len(payloads):
            raise HTTPException(404, f"no motion {i}")
        return JSONResponse(payloads[i])

    @app.get("/audio.wav")
    def audio():
        if not audio_path:
            raise HTTPException(404, "no audio")
        return FileResponse(audio_path, media_type="audio/wav")

    return app


@contextlib.contextmanager
def running_server(motions, *, labels=None, audio=None, host: str = "127.0.0.1", port: int = 0,
                   mask: bool = True, style: str = "textured"):
    """Run the viewer server in a background thread; yields its base URL (for tests/notebooks)."""
    with tempfile.TemporaryDirectory(prefix="headmotion-view-") as tmpdir:
        app = create_app(motions, labels=labels, audio_path=_write_wav(audio, tmpdir), mask=mask, style=style)
        with running_app(app, host=host, port=port) as url:
            yield url


@contextlib.contextmanager
def running_app(app, *, host: str = "127.0.0.1", port: int = 0, **uvicorn_options):
    """Serve an ASGI ``app`` with uvicorn in a background thread; yields its base URL.  The port is
    bound here first, so a port in use is a clear :class:`ParameterError` (``port=0``: any free
    port).  Shared by the viewer and the live page (:mod:`headmotion.web.live`)."""
    import time

    import uvicorn

    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, int(port)))
    except OSError as exc:
        sock.close()
        raise ParameterError(f"cannot listen on {host}:{port}: {exc.strerror or exc} "
                             "(is another program using the port? use --port)") from None
    actual = sock.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="off", **uvicorn_options))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        for _ in range(200):
            if server.started:
                break
            time.sleep(0.025)
        yield f"http://{host}:{actual}/"
    finally:
        server.should_exit = True
        thread.join(timeout=5)
        sock.close()


def wait_until_interrupted(url: str, *, open_browser: bool = True, announce=print) -> None:
    """Announce ``url``, open it in the browser if asked, and block until Ctrl-C (the end of
    ``headmotion view`` and ``headmotion view --live``)."""
    import time
    import webbrowser

    announce(url)
    if open_browser:
        with contextlib.suppress(Exception):
            webbrowser.open(url)
    try:
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass


def serve(motions, *, labels=None, audio=None, host: str = "127.0.0.1", port: int = 8765,
          mask: bool = True, style: str = "textured", open_browser: bool = True, announce=print):
    """Serve the viewer until interrupted (``headmotion view``)."""
    with running_server(motions, labels=labels, audio=audio, host=host, port=port, mask=mask,
                        style=style) as url:
        wait_until_interrupted(url, open_browser=open_browser, announce=announce)


__all__ = ["create_app", "page_app", "running_app", "running_server", "serve", "wait_until_interrupted", "motion_payload", "STATIC"]
