"""Per-participant trial plans: seeded random order, balanced A/B sides, training first
(thesis §4.2.3.1 "shown in a random order ... different for each participant", §5.5.1 "both types
of animation were shown an equal amount of times on the left and the right").

A plan is a list of trial dicts computed once when a participant registers (from the test seed
and the participant's number, so it is reproducible) and stored with the participant.  It holds
system names; only :func:`public_trial` — which replaces them by slot letters and opaque stimulus
ids — is ever sent to the browser.
"""

from __future__ import annotations

import hmac
from typing import Any

import numpy as np

from .config import Item, TestConfig


def make_plan(cfg: TestConfig, participant_number: int) -> list[dict[str, Any]]:
    """The ordered trials for participant ``participant_number`` (1, 2, ...).

    Training trials come first (flagged ``phase='training'``), then the test trials in a random
    order, with attention checks inserted after the configured number of test trials."""
    rng = np.random.default_rng([int(cfg.seed), int(participant_number)])
    training = _trials(cfg, cfg.training, "training", rng, participant_number)
    test = _trials(cfg, cfg.items, "test", rng, participant_number)
    for k, chk in sorted(enumerate(cfg.attention_checks), key=lambda t: -t[1].after):
        test.insert(chk.after, {"phase": "attention", "kind": "attention", "item": f"attention-{k}",
                                "question": chk.question, "options": list(chk.options),
                                "answer": chk.answer, "speaker": "", "group": ""})
    plan = training + test
    for i, t in enumerate(plan):
        t["index"] = i
    return plan


def _trials(cfg: TestConfig, items: tuple[Item, ...], phase: str, rng: np.random.Generator,
            participant_number: int) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for it in items:
        base = {"phase": phase, "item": it.id, "speaker": it.speaker, "group": it.group}
        if cfg.type == "mos_ref":
            for cond, stim in it.conditions.items():
                out.append({**base, "kind": "mos", "reference": it.reference.id,
                            "slots": [{"label": "A", "condition": cond, "stimulus": stim.id}]})
        elif cfg.type == "mushra":
            conds = list(it.conditions.items())
            order = rng.permutation(len(conds))
            slots = [{"label": _letter(k), "condition": conds[j][0], "stimulus": conds[j][1].id}
                     for k, j in enumerate(order)]
            out.append({**base, "kind": "mushra", "reference": it.reference.id, "slots": slots})
        else:
            for a, b in it.pairs:
                out.append({**base, "kind": "ab", "pair": [a, b],
                            "stimuli": {a: it.conditions[a].id, b: it.conditions[b].id}})
    order = rng.permutation(len(out))
    out = [out[j] for j in order]
    if cfg.type == "ab":
        _balance_sides(out, rng, participant_number)
    return out


def _balance_sides(trials: list[dict], rng: np.random.Generator, participant_number: int) -> None:
    """Give every unordered pair of conditions equally many left/right presentations.

    Within a participant the sides of one pair's trials are an exact half/half split (randomly
    assigned); with an odd count the extra one alternates between participants, so that over the
    panel each pair is also balanced."""
    by_pair: dict[tuple[str, str], list[dict]] = {}
    for t in trials:
        by_pair.setdefault(tuple(sorted(t["pair"])), []).append(t)
    for key, ts in by_pair.items():
        n = len(ts)
        first_left = n // 2 + (n % 2 if participant_number % 2 == 1 else 0)
        sides = np.array([True] * first_left + [False] * (n - first_left))
        sides = sides[rng.permutation(n)]
        for t, left_first in zip(ts, sides):
            a, b = key
            left, right = (a, b) if left_first else (b, a)
            stim = t.pop("stimuli")
            t.pop("pair")
            t["slots"] = [{"label": "left", "condition": left, "stimulus": stim[left]},
                          {"label": "right", "condition": right, "stimulus": stim[right]}]


def _letter(k: int) -> str:
    s = ""
    k += 1
    while k:
        k, r = divmod(k - 1, 26)
        s = chr(65 + r) + s
    return s


def public_trial(trial: dict[str, Any], cfg: TestConfig, *, secret: bytes = b"",
                 participant: int = 0) -> dict[str, Any]:
    """The part of a trial the participant's browser may see: no system names, no answer key.

    Stimulus ids are blinded per use (:func:`blind_id`), so the hidden reference of a MUSHRA
    item does not share its URL with the labelled reference."""
    out: dict[str, Any] = {"index": trial["index"], "phase": trial["phase"], "kind": trial["kind"]}
    if trial["kind"] == "attention":
        out["question"] = trial["question"]
        out["options"] = trial["options"]
        return out

    def info(sid: str, label: str) -> dict[str, Any]:
        return stimulus_info(cfg, sid, blind_id(sid, f"{participant}:{trial['index']}:{label}",
                                                secret))

    if trial.get("reference"):
        out["reference"] = info(trial["reference"], "reference")
    out["slots"] = [{"label": s["label"], "stimulus": info(s["stimulus"], s["label"])}
                    for s in trial["slots"]]
    return out


def stimulus_info(cfg: TestConfig, sid: str, public_id: str | None = None) -> dict[str, Any]:
    stim = cfg.stimuli[sid]
    pid = public_id or sid
    info: dict[str, Any] = {"id": pid, "kind": stim.kind}
    for k in stim.files():
        info[k] = f"/stimuli/{pid}/{k}"
    return info


def blind_id(sid: str, context: str, secret: bytes) -> str:
    """An opaque, stateless alias of stimulus ``sid`` for one use (``context``).

    ``nonce = HMAC(secret, context)[:8]``; ``alias = nonce || (sid XOR HMAC(secret, nonce)[:8])``.
    The server recovers ``sid`` with :func:`unblind_id`; without the secret two aliases of the same
    stimulus cannot be linked."""
    if not secret:
        return sid
    nonce = hmac.digest(secret, context.encode(), "sha256")[:8]
    return (nonce + _xor(bytes.fromhex(sid), hmac.digest(secret, nonce, "sha256")[:8])).hex()


def _xor(a: bytes, pad: bytes) -> bytes:
    n = min(len(a), len(pad))
    return (int.from_bytes(a[:n], "big") ^ int.from_bytes(pad[:n], "big")).to_bytes(n, "big")


def unblind_id(alias: str, secret: bytes) -> str | None:
    """The stimulus id behind an alias (``None`` if it is not a well-formed alias)."""
    if not secret:
        return alias
    try:
        raw = bytes.fromhex(alias)
    except ValueError:
        return None
    if len(raw) != 16:
        return None
    return _xor(raw[8:], hmac.digest(secret, raw[:8], "sha256")[:8]).hex()


__all__ = ["make_plan", "public_trial", "stimulus_info", "blind_id", "unblind_id"]
