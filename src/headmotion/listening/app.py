"""The listening-test web app (FastAPI): participants rate head-motion stimuli in the browser
(thesis §4.2.3–4.2.4 MOS with reference, §5.5.1 A/B forced choice; paper §4.4 MUSHRA).

Participant flow: consent → demographics questionnaire (configurable) → instructions → training
trials (stored, flagged ``phase='training'``) → test trials in a per-participant seeded random
order (with optional attention checks) → thank-you page.  The participant's token lives in the
browser's localStorage, so closing the tab and coming back resumes at the next unanswered trial.
The server only ever accepts an answer for the participant's *next* trial, so a rating cannot be
changed once given.

The browser never sees system names or file paths: stimuli are addressed by opaque ids and
conditions by slot letters (A, B, ... / left, right); the mapping stays on the server.

Admin API (token in ``Authorization: Bearer``, ``X-Admin-Token`` or ``?token=``):
``/api/admin/progress``, ``/api/admin/results.json``, ``/api/admin/results.csv``; page ``/admin``.

Libraries considered: webMUSHRA and HEMVIP (PHP/JS test frameworks for audio and gesture; not
embeddable in a Python package, no head viewer), Flask (no request validation built in).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import secrets
import time
from pathlib import Path
from typing import Any

from fastapi import FastAPI, HTTPException, Request
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel, ConfigDict, Field

from .config import TestConfig
from .db import ANSWER_COLUMNS, Conflict, Database, NotFound
from .plan import make_plan, public_trial, unblind_id

STATIC = Path(__file__).resolve().parent / "static"
VIEWER_STATIC = Path(__file__).resolve().parents[1] / "web" / "static"
MEDIA_TYPES = {".mp4": "video/mp4", ".m4v": "video/mp4", ".webm": "video/webm",
               ".ogv": "video/ogg", ".wav": "audio/wav", ".mp3": "audio/mpeg",
               ".ogg": "audio/ogg", ".flac": "audio/flac", ".m4a": "audio/mp4"}


class ConsentBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    consent: bool


class DemographicsBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    answers: dict[str, str | int | float | None] = Field(default_factory=dict)


class AnswerBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    trial_index: int
    rating: int | None = None                     # MOS with reference (1..points)
    ratings: dict[str, float] | None = None       # MUSHRA: slot letter -> 0..100
    choice: str | None = None                     # A/B: left|right; attention: option
    response_ms: float | None = Field(default=None, ge=0, le=24 * 3600 * 1000)


def _bad(msg: str, code: int = 422):
    raise HTTPException(status_code=code, detail=msg)


def create_app(cfg: TestConfig, *, database_url: str | None = None,
               admin_token: str | None = None) -> FastAPI:
    """Build the app for one test.

    Parameters
    ----------
    cfg : TestConfig
        From :func:`headmotion.listening.config.load_config`.
    database_url : str, optional
        Defaults to the config's ``database`` or ``sqlite:///<config folder>/results/<name>.sqlite``.
    admin_token : str, optional
        Defaults to the config's ``admin_token``, then ``$HEADMOTION_ADMIN_TOKEN``, then a random
        token (available as ``app.state.admin_token``).
    """
    url = database_url or cfg.database or cfg.default_database_url()
    db = Database(url)
    previous = db.get_meta("config")
    if previous and previous.get("digest") != cfg.digest and db.progress():
        import warnings

        warnings.warn(f"the configuration {cfg.path} changed since participants started this test "
                      f"(database {url}); their stored trial order is kept", stacklevel=2)
    db.set_meta("config", {"name": cfg.name, "type": cfg.type, "digest": cfg.digest,
                           "path": str(cfg.path), "hidden_reference": cfg.hidden_reference,
                           "anchor": cfg.anchor, "screening_threshold": cfg.screening_threshold,
                           "screening_fraction": cfg.screening_fraction,
                           "scale_points": cfg.scale_points,
                           "demographics": [q.name for q in cfg.demographics]})
    secret_hex = db.get_meta("secret")
    if secret_hex is None:
        secret_hex = secrets.token_hex(32)
        db.set_meta("secret", secret_hex)
    secret = bytes.fromhex(secret_hex)
    token = admin_token or cfg.admin_token or os.environ.get("HEADMOTION_ADMIN_TOKEN") \
        or secrets.token_urlsafe(16)

    app = FastAPI(title=f"headmotion listening test: {cfg.title}", docs_url=None, redoc_url=None,
                  openapi_url=None)
    app.state.cfg = cfg
    app.state.db = db
    app.state.admin_token = token
    app.state.database_url = url
    motion_cache: dict[str, bytes] = {}

    @app.middleware("http")
    async def no_store(request: Request, call_next):
        resp = await call_next(request)
        if request.url.path.startswith("/api/"):
            resp.headers["Cache-Control"] = "no-store"
        return resp

    # -- pages -----------------------------------------------------------------------------
    @app.get("/", response_class=HTMLResponse)
    def index():
        return FileResponse(STATIC / "index.html", media_type="text/html")

    @app.get("/admin", response_class=HTMLResponse)
    def admin_page():
        return FileResponse(STATIC / "admin.html", media_type="text/html")

    @app.get("/favicon.ico")
    def favicon():
        return Response(status_code=204)

    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    if VIEWER_STATIC.is_dir():
        app.mount("/viewer", StaticFiles(directory=VIEWER_STATIC), name="viewer")

    # -- participant API -------------------------------------------------------------------
    @app.get("/api/test")
    def test_info():
        info = cfg.public_info()
        info["viewer"] = _viewer_module()
        return info

    @app.post("/api/participants", status_code=201)
    def register(body: ConsentBody, request: Request):
        if not body.consent:
            _bad("consent is required to take part", 400)
        first = "demographics" if cfg.demographics else "instructions"
        p = db.create_participant(lambda n: make_plan(cfg, n),
                                  user_agent=request.headers.get("user-agent", ""), stage=first)
        return {"token": p["token"], "stage": p["stage"]}

    def _participant(token: str) -> dict[str, Any]:
        try:
            return db.participant(token)
        except NotFound:
            raise HTTPException(status_code=404, detail="unknown participant") from None

    @app.get("/api/p/{token}/state")
    def state(token: str):
        p = _participant(token)
        out: dict[str, Any] = {"stage": p["stage"],
                               "progress": {"done": p["next_trial"], "total": p["n_trials"]}}
        if p["stage"] == "trials" and p["next_trial"] < p["n_trials"]:
            try:
                out["trial"] = public_trial(p["plan"][p["next_trial"]], cfg, secret=secret,
                                            participant=p["id"])
            except KeyError:
                raise HTTPException(status_code=409, detail=(
                    "this participant's trials name stimuli that are no longer in the test "
                    "configuration (was it edited after the test started?)")) from None
        return out

    @app.post("/api/p/{token}/demographics")
    def demographics(token: str, body: DemographicsBody):
        _participant(token)
        clean = _check_demographics(cfg, body.answers)
        _advance(token, "demographics", "instructions", demographics=clean)
        return {"stage": "instructions"}

    @app.post("/api/p/{token}/start")
    def start(token: str):
        _participant(token)
        _advance(token, "instructions", "trials")
        return {"stage": "trials"}

    def _advance(token: str, expect: str, stage: str, **kw):
        try:
            db.set_stage(token, expect=expect, stage=stage, **kw)
        except NotFound:
            raise HTTPException(status_code=404, detail="unknown participant") from None
        except Conflict as exc:
            raise HTTPException(status_code=409, detail=str(exc)) from None

    @app.post("/api/p/{token}/answer")
    def answer(token: str, body: AnswerBody):
        p = _participant(token)
        if not 0 <= body.trial_index < p["n_trials"]:
            _bad(f"trial_index must be in [0, {p['n_trials'] - 1}]; got {body.trial_index}")
        trial = p["plan"][body.trial_index]
        rows = _answer_rows(cfg, trial, body)
        try:
            res = db.submit(token, body.trial_index, rows)
        except NotFound:
            raise HTTPException(status_code=404, detail="unknown participant") from None
        except Conflict as exc:
            raise HTTPException(status_code=409, detail=str(exc)) from None
        return res

    # -- stimuli ---------------------------------------------------------------------------
    @app.get("/stimuli/{alias}/{kind}")
    def stimulus(alias: str, kind: str):
        sid = unblind_id(alias, secret)
        stim = cfg.stimuli.get(sid) if sid else None
        if stim is None or kind not in stim.files():
            raise HTTPException(status_code=404, detail="unknown stimulus")
        path = stim.files()[kind].resolve()
        if not path.is_relative_to(cfg.root) or not path.is_file():  # symlinks out, or deleted
            raise HTTPException(status_code=404, detail="unknown stimulus")
        if kind == "motion":
            if sid not in motion_cache:
                motion_cache[sid] = json.dumps(_motion_json(path)).encode()
            return Response(motion_cache[sid], media_type="application/json",
                            headers={"Cache-Control": "max-age=3600"})
        return FileResponse(path, media_type=MEDIA_TYPES.get(path.suffix.lower(),
                                                             "application/octet-stream"),
                            headers={"Cache-Control": "max-age=3600"})

    # -- admin -----------------------------------------------------------------------------
    def _require_admin(request: Request):
        given = request.headers.get("x-admin-token") or request.query_params.get("token") or ""
        auth = request.headers.get("authorization", "")
        if auth.lower().startswith("bearer "):
            given = auth[7:].strip()
        if not given or not secrets.compare_digest(given.encode(), token.encode()):
            raise HTTPException(status_code=401, detail="admin token required")

    @app.get("/api/admin/progress")
    def admin_progress(request: Request):
        _require_admin(request)
        ps = db.progress()
        return {"test": cfg.name, "type": cfg.type, "participants": ps,
                "n_participants": len(ps), "n_finished": sum(p["stage"] == "done" for p in ps),
                "n_answers": db.count_answers()}

    @app.get("/api/admin/results.json")
    def admin_json(request: Request):
        _require_admin(request)
        return JSONResponse(results_document(cfg, db),
                            headers={"Content-Disposition":
                                     f'attachment; filename="{cfg.name}-results.json"'})

    @app.get("/api/admin/results.csv")
    def admin_csv(request: Request):
        _require_admin(request)
        return Response(results_csv(db), media_type="text/csv",
                        headers={"Content-Disposition":
                                 f'attachment; filename="{cfg.name}-results.csv"'})

    return app


def _viewer_module() -> str | None:
    """URL of the viewer component's ES module, if the web viewer is installed."""
    for name in ("viewer.js", "headviewer.js", "head-viewer.js", "index.js"):
        if (VIEWER_STATIC / name).is_file():
            return f"/viewer/{name}"
    return None


def _check_demographics(cfg: TestConfig, given: dict[str, Any]) -> dict[str, Any]:
    known = {q.name: q for q in cfg.demographics}
    for k in given:
        if k not in known:
            _bad(f"unknown demographics question {k!r}")
    clean: dict[str, Any] = {}
    for q in cfg.demographics:
        v = given.get(q.name)
        if v is None or (isinstance(v, str) and not v.strip()):
            if q.required:
                _bad(f"please answer {q.label!r}")
            continue
        if q.type == "choice":
            if str(v) not in q.options:
                _bad(f"{q.label!r} must be one of {list(q.options)}; got {v!r}")
            v = str(v)
        elif q.type == "number":
            try:
                v = float(v)
            except (TypeError, ValueError):
                _bad(f"{q.label!r} must be a number; got {v!r}")
            if not math.isfinite(v):
                _bad(f"{q.label!r} must be a finite number")
        else:
            v = str(v)[:500]
        clean[q.name] = v
    return clean


def _answer_rows(cfg: TestConfig, trial: dict, body: AnswerBody) -> list[dict[str, Any]]:
    """Validate an answer against its trial and turn it into rows; 422 on anything wrong."""
    base = {"phase": trial["phase"], "kind": trial["kind"], "item": trial["item"],
            "speaker": trial.get("speaker", ""), "grp": trial.get("group", ""),
            "response_ms": body.response_ms}
    kind = trial["kind"]
    given = {k for k in ("rating", "ratings", "choice") if getattr(body, k) is not None}
    want = {"mos": "rating", "mushra": "ratings", "ab": "choice", "attention": "choice"}[kind]
    if given != {want}:
        _bad(f"a {kind} trial needs exactly '{want}'; got {sorted(given) or 'nothing'}")
    if kind == "mos":
        r = body.rating
        if not 1 <= r <= cfg.scale_points:
            _bad(f"rating must be an integer in [1, {cfg.scale_points}]; got {r}")
        s = trial["slots"][0]
        return [{**base, "slot": s["label"], "condition": s["condition"], "value": float(r)}]
    if kind == "mushra":
        slots = {s["label"]: s for s in trial["slots"]}
        if set(body.ratings) != set(slots):
            _bad(f"ratings must give exactly the slots {sorted(slots)}; got {sorted(body.ratings)}")
        rows = []
        for label, v in body.ratings.items():
            if not (math.isfinite(v) and 0 <= v <= 100):
                _bad(f"rating of {label} must be in [0, 100]; got {v}")
            rows.append({**base, "slot": label, "condition": slots[label]["condition"],
                         "value": float(v)})
        return rows
    if kind == "ab":
        slots = {s["label"]: s for s in trial["slots"]}
        if body.choice not in slots:
            _bad(f"choice must be 'left' or 'right'; got {body.choice!r}")
        other = next(s for lab, s in slots.items() if lab != body.choice)
        return [{**base, "slot": body.choice, "condition": slots[body.choice]["condition"],
                 "value": 1.0, "other": other["condition"]}]
    if body.choice not in trial["options"]:
        _bad(f"choice must be one of {trial['options']}; got {body.choice!r}")
    return [{**base, "slot": "choice", "condition": body.choice,
             "value": 1.0 if body.choice == trial["answer"] else 0.0, "other": trial["answer"]}]


def _motion_json(path: Path) -> dict[str, Any]:
    """A motion file as ``{"fps", "rotvec": [[x, y, z], ...]}`` for the browser viewer."""
    try:
        from ..io import load_motion  # the motion-format owner's reader, when present
    except ImportError:
        load_motion = None
    if load_motion is not None:
        m = load_motion(path)
        rotvec, fps = m.rotvec, m.fps
    else:
        import numpy as np

        if path.suffix.lower() == ".npz":
            with np.load(path, allow_pickle=False) as z:
                rotvec, fps = np.asarray(z["rotvec"], float), float(z["fps"])
        else:
            d = json.loads(path.read_text())
            rotvec, fps = np.asarray(d["rotvec"], float), float(d["fps"])
    return {"fps": float(fps), "rotvec": [[round(float(v), 6) for v in r] for r in rotvec]}


def results_document(cfg: TestConfig, db: Database) -> dict[str, Any]:
    """Everything the analysis needs: test settings, participants (demographics) and answers."""
    return {
        "format": "headmotion-listening-results/1",
        "exported_at": time.time(),
        "test": {"name": cfg.name, "type": cfg.type, "title": cfg.title, "digest": cfg.digest,
                 "scale_points": cfg.scale_points, "hidden_reference": cfg.hidden_reference,
                 "anchor": cfg.anchor, "screening_threshold": cfg.screening_threshold,
                 "screening_fraction": cfg.screening_fraction,
                 "demographics": [q.name for q in cfg.demographics]},
        "participants": db.progress(),
        "answers": db.answer_rows(),
    }


def results_csv(db: Database) -> str:
    rows = db.answer_rows()
    demo = sorted({k for r in rows for k in r if k.startswith("demo_")})
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(ANSWER_COLUMNS) + demo, extrasaction="ignore",
                       lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow(r)
    return buf.getvalue()


__all__ = ["create_app", "results_document", "results_csv"]
