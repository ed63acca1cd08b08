"""The listening ruler: a model's listening head on conversations built from real speech
(``headmotion evaluate-listening``; docs/listening.md).

For each conversation (:mod:`.conversations`) and seed the model synthesises this head's side
hearing the other's (``synthesize(own, hear=heard)``).  From the **output motion** and the other's
audio alone (:mod:`..measures.backchannel`) it reports: the nods per minute of heard speech, the
share of nods that follow a Praat-read cue against circularly shifted nods (per seed and pooled),
and the head's speed in the other's turns.  Beside the head, two levels on the same conversation:

* **cue-led nods** — the same model not listening (``listening=0``) with a 3° nod planted 0.7 s
  after every cue the ruler reads: a head that follows every cue (the strongest level here; it
  passes by construction, which shows the ruler can pass);
* **not listening** — ``listening=0`` alone: a layer that adds nothing (it should fail).

``stream_difference`` checks that the live layer equals the offline one on a conversation: the
frames of :func:`~headmotion.synthesis.open_stream` fed 20 ms chunks (the heard audio of each chunk
before its speech) against :func:`~headmotion.synthesis.synthesize`'s.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..measures.backchannel import FollowResult, Trial, follow_test, motion_nods, praat_cues

#: the nod planted for the cue-led level: a raised cosine of the pitch, this deep and long, starting
#: this long after the cue's region start (Ward & Tsukahara's P5)
PLANTED_DEG, PLANTED_S, PLANTED_AFTER_S = 3.0, 0.4, 0.7
#: the head's speed is measured in the other's turns from this long after each starts (past the easing)
SPEED_SKIP_S = 0.7


HEADS = ("listening", "cue-led nods", "not listening")


@dataclass
class ConversationRun:
    """What each head did in one conversation: its nods (s) and speed (°/s) per seed."""

    conversation: object        # the :class:`~.conversations.Conversation`
    cues: np.ndarray
    nods: dict = field(default_factory=dict)    # head -> [nods of each seed]
    speed: dict = field(default_factory=dict)   # head -> [°/s of each seed]
    first: dict = field(default_factory=dict)   # head -> the first seed's Motion (for a figure)


@dataclass
class ListeningRow:
    """One group of conversations (their voices and condition), for one head: hits per seed pooled
    over the group's conversations."""

    voices: str
    condition: str
    head: str
    conversations: int
    heard_s: float
    result: FollowResult
    speed: list[float]

    @property
    def nods_per_min(self) -> float:
        return float(np.mean(self.result.nods)) / (self.heard_s / 60.0)

    @property
    def cues_per_min(self) -> float:
        return self.result.n_cues / (self.heard_s / 60.0)


def speed_in(motion, spans) -> float:
    """Mean speed (°/s; 6 Hz low-pass at 25 fps, the waiting measure's footing) in ``spans``, from
    :data:`SPEED_SKIP_S` after each span starts."""
    from ..detection.detectability import FPS, prepare

    x = prepare(motion)
    v = np.linalg.norm(np.diff(x, axis=0), axis=1) * FPS
    keep = np.zeros(len(v), bool)
    for a, b in spans:
        keep[int((a + SPEED_SKIP_S) * FPS):int(b * FPS)] = True
    return float(v[keep[:len(v)]].mean()) if keep[:len(v)].any() else float("nan")


def planted(motion, cues):
    """``motion`` with a :data:`PLANTED_DEG` nod (raised cosine of pitch) starting
    :data:`PLANTED_AFTER_S` after each cue."""
    from ...listener.head import turned
    from ...types import Motion

    rv = np.asarray(motion.rotvec, dtype=np.float64).copy()
    n = max(2, int(round(PLANTED_S * motion.fps)))
    bump = np.radians(PLANTED_DEG) * 0.5 * (1.0 - np.cos(2.0 * np.pi * np.arange(n) / (n - 1)))
    pitch = np.zeros(len(rv))
    for c in cues:
        a = int(round((c + PLANTED_AFTER_S) * motion.fps))
        if 0 <= a < len(rv):
            m = min(n, len(rv) - a)
            pitch[a:a + m] += bump[:m]
    for k in np.flatnonzero(pitch):
        rv[k] = turned(rv[k], (pitch[k], 0.0, 0.0))
    return Motion(rv, motion.fps)


def run_conversation(conv, model, *, seeds, listening: float = 1.0, levels: bool = True) -> ConversationRun:
    """The listening head (and, with ``levels``, the cue-led and not-listening levels) on one
    conversation, each seed, read by the ruler."""
    from ...synthesis import synthesize

    run = ConversationRun(conv, praat_cues(conv.heard, conv.spans))
    for seed in seeds:
        motions = {"listening": synthesize(conv.own, model, seed=seed, hear=conv.heard, listening=listening)[0]}
        if levels:
            still = synthesize(conv.own, model, seed=seed, hear=conv.heard, listening=0)[0]
            motions["cue-led nods"] = planted(still, run.cues)
            motions["not listening"] = still
        for head, m in motions.items():
            run.first.setdefault(head, m)
            run.nods.setdefault(head, []).append(motion_nods(m, conv.spans))
            run.speed.setdefault(head, []).append(speed_in(m, conv.spans))
    return run


def group_rows(runs, *, shifts: int = 1000) -> list[ListeningRow]:
    """Rows by (voices, condition) and head, each seed's hits pooled over the group's conversations."""
    groups: dict = {}
    for r in runs:
        groups.setdefault((r.conversation.voices, r.conversation.condition), []).append(r)
    rows = []
    for (voices, condition), members in groups.items():
        for head in HEADS:
            have = [r for r in members if head in r.nods]
            if not have:
                continue
            res = follow_test([Trial(r.nods[head], r.cues, r.conversation.spans) for r in have], shifts=shifts)
            speed = np.mean([r.speed[head] for r in have], axis=0).tolist()
            rows.append(ListeningRow(voices, condition, head, len(have), sum(r.conversation.heard_s for r in have),
                                     res, speed))
    return rows


def stream_difference(conv, model, *, seed: int = 0, listening: float = 1.0, chunk_s: float = 0.02) -> float:
    """Largest difference (degrees) between the streamed and the offline listening head."""
    from ...synthesis import open_stream, synthesize

    ref = synthesize(conv.own, model, seed=seed, hear=conv.heard, listening=listening)[0]
    s = open_stream(model, seed=seed, sample_rate=conv.own.sample_rate, heard_rate=conv.heard.sample_rate,
                    listening=listening)
    step = int(round(chunk_s * conv.own.sample_rate))
    own = conv.own.samples.astype(np.float32)
    heard = conv.heard.samples.astype(np.float32)
    parts = []
    for i in range(0, len(own), step):
        s.hear(heard[i:i + step])
        parts.append(np.asarray(s.push(own[i:i + step]).rotvec).reshape(-1, 3))
    parts.append(np.asarray(s.flush().rotvec).reshape(-1, 3))
    got = np.vstack(parts)
    n = min(len(got), len(ref))
    return float(np.degrees(np.abs(got[:n] - np.asarray(ref.rotvec)[:n]).max())) if n else float("nan")


__all__ = ["ConversationRun", "ListeningRow", "HEADS", "run_conversation", "group_rows", "stream_difference", "planted",
           "speed_in"]
