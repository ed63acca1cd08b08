"""The two requests of every trial — ``GET /api/p/{token}/state`` and
``POST /api/p/{token}/answer`` — as a plain ASGI app in front of the FastAPI app.

Thesis §4.2.3.1 (one rating per stimulus, no going back) and §5.5.1 (A/B): the participant's page
reads its state (stage, progress, the next trial with blinded stimulus ids) and posts the answer;
the answer is checked against the trial (:func:`answer_rows`) and stored exactly once
(:meth:`headmotion.listening.db.Database.submit_async`).

Why not FastAPI routes: the server's target is an answer p95 under 250 ms with 300 participants
answering every 50 ms on a two-core machine, i.e. ~1,000 answers and 1,000 state reads a second.
FastAPI's routing, dependency solving, thread-pool hop and ``jsonable_encoder`` cost ~0.1 ms (an
async route) to ~0.7 ms (the sync state route with its nested JSON) of CPU per request; here a
request costs tens of microseconds.  Request bodies are still validated by the same pydantic
model (:class:`AnswerBody`, ``model_validate_json``), errors keep FastAPI's shape
(``{"detail": "..."}``; validation errors ``{"detail": [...]}`` with status 422), and the
:class:`~headmotion.listening.app.Guard` middleware in front of this app still applies the Host
allow-list, body limit, Origin check and security headers.  Every other route stays in FastAPI.
"""

from __future__ import annotations

import json
import math
from typing import Any

from fastapi import HTTPException
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from .config import TestConfig
from .db import Conflict, Database, NotFound
from .plan import public_trial

JSON_HEADERS = [(b"content-type", b"application/json")]
_TRIAL_CACHE_MAX = 100_000


class AnswerBody(BaseModel):
    model_config = ConfigDict(extra="forbid")
    trial_index: int
    rating: int | None = None                     # MOS with reference (1..points)
    ratings: dict[str, float] | None = None       # MUSHRA: slot letter -> 0..100
    choice: str | None = None                     # A/B: left|right; attention: option
    response_ms: float | None = Field(default=None, ge=0, le=24 * 3600 * 1000)


def bad(msg: str, code: int = 422):
    raise HTTPException(status_code=code, detail=msg)


def answer_rows(cfg: TestConfig, trial: dict, body: AnswerBody) -> list[dict[str, Any]]:
    """Validate an answer against its trial and turn it into rows; 422 on anything wrong."""
    base = {"phase": trial["phase"], "kind": trial["kind"], "item": trial["item"],
            "speaker": trial.get("speaker", ""), "grp": trial.get("group", ""),
            "response_ms": body.response_ms}
    kind = trial["kind"]
    given = {k for k in ("rating", "ratings", "choice") if getattr(body, k) is not None}
    want = {"mos": "rating", "mushra": "ratings", "ab": "choice", "attention": "choice"}[kind]
    if given != {want}:
        bad(f"a {kind} trial needs exactly '{want}'; got {sorted(given) or 'nothing'}")
    if kind == "mos":
        r = body.rating
        if not 1 <= r <= cfg.scale_points:
            bad(f"rating must be an integer in [1, {cfg.scale_points}]; got {r}")
        s = trial["slots"][0]
        return [{**base, "slot": s["label"], "condition": s["condition"], "value": float(r)}]
    if kind == "mushra":
        slots = {s["label"]: s for s in trial["slots"]}
        if set(body.ratings) != set(slots):
            bad(f"ratings must give exactly the slots {sorted(slots)}; got {sorted(body.ratings)}")
        rows = []
        for label, v in body.ratings.items():
            if not (math.isfinite(v) and 0 <= v <= 100):
                bad(f"rating of {label} must be in [0, 100]; got {v}")
            rows.append({**base, "slot": label, "condition": slots[label]["condition"],
                         "value": float(v)})
        return rows
    if kind == "ab":
        slots = {s["label"]: s for s in trial["slots"]}
        if body.choice not in slots:
            bad(f"choice must be 'left' or 'right'; got {body.choice!r}")
        other = next(s for lab, s in slots.items() if lab != body.choice)
        return [{**base, "slot": body.choice, "condition": slots[body.choice]["condition"],
                 "value": 1.0, "other": other["condition"]}]
    if body.choice not in trial["options"]:
        bad(f"choice must be one of {trial['options']}; got {body.choice!r}")
    return [{**base, "slot": "choice", "condition": body.choice,
             "value": 1.0 if body.choice == trial["answer"] else 0.0, "other": trial["answer"]}]


async def _respond(send, status: int, body: bytes, headers=JSON_HEADERS) -> None:
    await send({"type": "http.response.start", "status": status,
                "headers": [*headers, (b"content-length", str(len(body)).encode())]})
    await send({"type": "http.response.body", "body": body})


async def _detail(send, status: int, detail: Any, headers=()) -> None:
    await _respond(send, status, json.dumps({"detail": detail}).encode(), [*JSON_HEADERS, *headers])


class TrialEndpoints:
    """ASGI app: the state and answer requests; everything else goes to ``app``.

    Parameters
    ----------
    app : ASGI app
        The rest of the API (FastAPI).
    cfg, db, secret
        The test, its database and the secret that blinds stimulus ids.
    """

    def __init__(self, app, *, cfg: TestConfig, db: Database, secret: bytes):
        self.app, self.cfg, self.db, self.secret = app, cfg, db, secret
        self._trials: dict[tuple[int, int], str] = {}  # (participant id, trial) -> public JSON

    async def __call__(self, scope, receive, send):
        if scope["type"] == "http":
            path = scope["path"]
            if path.startswith("/api/p/"):
                token, sep, what = path[7:].partition("/")
                if sep and token and what in ("state", "answer"):
                    method = scope["method"]
                    want = "GET" if what == "state" else "POST"
                    if method != want:
                        return await _detail(send, 405, "Method Not Allowed",
                                             [(b"allow", want.encode())])
                    try:
                        if what == "state":
                            body = await self.state(token)
                        else:
                            body = await self.answer(token, await _read_body(receive))
                    except HTTPException as exc:
                        return await _detail(send, exc.status_code, exc.detail,
                                             [(k.lower().encode(), v.encode())
                                              for k, v in (exc.headers or {}).items()])
                    except ValidationError as exc:
                        detail = exc.json(include_url=False).encode()
                        return await _respond(send, 422, b'{"detail":' + detail + b"}")
                    except _Disconnected:
                        return None
                    return await _respond(send, 200, body)
        return await self.app(scope, receive, send)

    async def state(self, token: str) -> bytes:
        """``{"stage", "progress": {"done", "total"}, "trial"?}`` as JSON bytes."""
        try:
            p = await self.db.progress_of_async(token)
        except NotFound:
            bad("unknown participant", 404)
        head = json.dumps({"stage": p["stage"],
                           "progress": {"done": p["next_trial"], "total": p["n_trials"]}})
        if p["stage"] == "trials" and p["next_trial"] < p["n_trials"]:
            return (head[:-1] + ', "trial": ' + self._public_trial(p) + "}").encode()
        return head.encode()

    def _public_trial(self, p: dict[str, Any]) -> str:
        key = (p["id"], p["next_trial"])
        got = self._trials.get(key)
        if got is None:
            try:
                got = json.dumps(public_trial(p["plan"][p["next_trial"]], self.cfg,
                                              secret=self.secret, participant=p["id"]))
            except KeyError:
                raise HTTPException(status_code=409, detail=(
                    "this participant's trials name stimuli that are no longer in the test "
                    "configuration (was it edited after the test started?)")) from None
            if len(self._trials) >= _TRIAL_CACHE_MAX:
                self._trials.clear()
            self._trials[key] = got
        return got

    async def answer(self, token: str, raw: bytes) -> bytes:
        """Check the answer against the participant's next trial and store it exactly once;
        ``{"stored", "duplicate", "next_trial", "done"}`` once it is committed."""
        body = AnswerBody.model_validate_json(raw)
        try:
            _pid, plan = await self.db.plan_async(token)
        except NotFound:
            bad("unknown participant", 404)
        if not 0 <= body.trial_index < len(plan):
            bad(f"trial_index must be in [0, {len(plan) - 1}]; got {body.trial_index}")
        rows = answer_rows(self.cfg, plan[body.trial_index], body)
        try:
            res = await self.db.submit_async(token, body.trial_index, rows)
        except NotFound:
            bad("unknown participant", 404)
        except Conflict as exc:
            bad(str(exc), 409)
        return json.dumps(res).encode()


class _Disconnected(Exception):
    pass


async def _read_body(receive) -> bytes:
    chunks = []
    while True:
        msg = await receive()
        if msg["type"] == "http.disconnect":
            raise _Disconnected
        chunks.append(msg.get("body", b""))
        if not msg.get("more_body", False):
            return b"".join(chunks)


__all__ = ["TrialEndpoints", "AnswerBody", "answer_rows"]
