"""The participant API (registration, demographics, start) and the blinded stimuli.

The state read and the answer of every trial are not here: they skip FastAPI
(:mod:`headmotion.listening.trials_api`).  These handlers are coroutines: their database calls
go to the SQLite writer thread (or, on PostgreSQL, a worker thread), not through FastAPI's
thread pool.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import math
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Depends, HTTPException, Request
from fastapi.responses import FileResponse, Response
from pydantic import BaseModel, ConfigDict, Field

from ..config import TestConfig
from ..db import Conflict, Full, NotFound, RateLimited
from ..guard import is_loopback
from ..plan import make_plan, unblind_id
from ..trials_api import bad as _bad
from . import ServerContext, server_context

VIEWER_STATIC = Path(__file__).resolve().parents[2] / "web" / "static"
MEDIA_TYPES = {".mp4": "video/mp4", ".m4v": "video/mp4", ".webm": "video/webm",
               ".ogv": "video/ogg", ".wav": "audio/wav", ".mp3": "audio/mpeg",
               ".ogg": "audio/ogg", ".flac": "audio/flac", ".m4a": "audio/mp4"}

router = APIRouter()


class ConsentBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    consent: bool


class DemographicsBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    answers: dict[str, str | int | float | None] = Field(default_factory=dict)


@router.get("/api/test")
def test_info(ctx: ServerContext = Depends(server_context)):
    info = ctx.cfg.public_info()
    info["viewer"] = viewer_module()
    return info


@router.post("/api/participants", status_code=201)
async def register(body: ConsentBody, request: Request, ctx: ServerContext = Depends(server_context)):
    cfg = ctx.cfg
    if not body.consent:
        _bad("consent is required to take part", 400)
    first = "demographics" if cfg.demographics else "instructions"
    client = request.client.host if request.client else ""
    # the lab machine itself (participants at the experimenter's computer) is not limited
    addr = "" if is_loopback(client) else \
        hmac.new(ctx.secret, b"addr:" + client.encode(), hashlib.sha256).hexdigest()[:32]
    try:
        p = await ctx.db.create_participant_async(
            lambda n: make_plan(cfg, n), user_agent=request.headers.get("user-agent", ""),
            stage=first, addr=addr, max_participants=cfg.max_participants,
            per_address=cfg.registrations_per_address, window_s=cfg.registration_window_s)
    except Full:
        raise HTTPException(status_code=403, detail="this test is full; thank you for your "
                                                    "interest") from None
    except RateLimited:
        raise HTTPException(status_code=429, detail="too many registrations from this address; "
                                                    "try again later",
                            headers={"Retry-After": str(int(cfg.registration_window_s))}) from None
    return {"token": p["token"], "stage": p["stage"]}


async def _known(ctx: ServerContext, token: str) -> None:
    """404 for a token that names no participant (the plan is cached after the first look)."""
    try:
        await ctx.db.plan_async(token)
    except NotFound:
        raise HTTPException(status_code=404, detail="unknown participant") from None


async def _advance(ctx: ServerContext, token: str, expect: str, stage: str, **kw):
    try:
        await ctx.db.set_stage_async(token, expect=expect, stage=stage, **kw)
    except NotFound:
        raise HTTPException(status_code=404, detail="unknown participant") from None
    except Conflict as exc:
        raise HTTPException(status_code=409, detail=str(exc)) from None


@router.post("/api/p/{token}/demographics")
async def demographics(token: str, body: DemographicsBody, ctx: ServerContext = Depends(server_context)):
    await _known(ctx, token)
    clean = check_demographics(ctx.cfg, body.answers)
    await _advance(ctx, token, "demographics", "instructions", demographics=clean)
    return {"stage": "instructions"}


@router.post("/api/p/{token}/start")
async def start(token: str, ctx: ServerContext = Depends(server_context)):
    await _known(ctx, token)
    await _advance(ctx, token, "instructions", "trials")
    return {"stage": "trials"}


@router.get("/stimuli/{alias}/{kind}")
def stimulus(alias: str, kind: str, ctx: ServerContext = Depends(server_context)):
    cfg = ctx.cfg
    sid = unblind_id(alias, ctx.secret)
    stim = cfg.stimuli.get(sid) if sid else None
    if stim is None or kind not in stim.files():
        raise HTTPException(status_code=404, detail="unknown stimulus")
    path = stim.files()[kind].resolve()
    if not path.is_relative_to(cfg.root) or not path.is_file():  # symlinks out, or deleted
        raise HTTPException(status_code=404, detail="unknown stimulus")
    if kind == "motion":
        if sid not in ctx.motion_cache:
            ctx.motion_cache[sid] = json.dumps(motion_json(path)).encode()
        return Response(ctx.motion_cache[sid], media_type="application/json",
                        headers={"Cache-Control": "max-age=3600"})
    return FileResponse(path, media_type=MEDIA_TYPES.get(path.suffix.lower(),
                                                         "application/octet-stream"),
                        headers={"Cache-Control": "max-age=3600"})


def viewer_module() -> str | None:
    """URL of the viewer component's ES module, if the web viewer is installed."""
    for name in ("viewer.js", "headviewer.js", "head-viewer.js", "index.js"):
        if (VIEWER_STATIC / name).is_file():
            return f"/viewer/{name}"
    return None


def check_demographics(cfg: TestConfig, given: dict[str, Any]) -> dict[str, Any]:
    """The demographics answers checked against the configured questions (400 for an unknown
    question, a missing required answer or a value of the wrong kind); free text cut at 500."""
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


def motion_json(path: Path) -> dict[str, Any]:
    """A motion file as ``{"fps", "rotvec": [[x, y, z], ...]}`` for the browser viewer."""
    try:
        from ...io import load_motion  # the motion-format owner's reader, when present
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
