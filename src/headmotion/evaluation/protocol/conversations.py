"""Conversations built from real speech, for the listening ruler (``headmotion evaluate-listening``).

No recorded conversation with a listener's head is reachable here, so conversations are made: this
head's side (voice A, three turns) and the other party's (voice B, cut into turns of about 6 s at
its quietest 50 ms), 0.4–0.9 s of silence between turns, on one timeline.  B is either **one
voice** throughout, or **several voices**, two turns each.  Each conversation exists clean and with
the other party's channel degraded (:mod:`.degraded`: ``noise20``, ``telephone``).

Two sets of voices, so that the listening head's settings are chosen on one and reported on the
other (:data:`VOICE_SETS`): ``choice`` from the talking-video corpus's sources styletalk, sadtalker
and mimictalk; ``report`` from the corpus's dfrf and from ``../shared/data/speech`` (broadcast,
phone-like, studio, Mandarin, Japanese).  This head's own voice is one of the bundled
examples (a different one per set).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import FormatError, ParameterError
from ...types import Audio
from .degraded import check_degradation, degrade

SR = 16000
TURN_S = 6.0
OWN_TURNS = 3
HEARD_MAX_S = 66.0

#: set → (one-voice conversations: [speaker, …], several voices: [speaker, …], this head's voice);
#: a speaker is a corpus speaker (all its recordings, in the manifest's order) or a file of the
#: shared data's ``speech/`` folder
VOICE_SETS = {
    "choice": (["andrew", "feifeili", "german"],
               ["radio2", "radio34", "alexandriaocasiocortez", "bobmenendez", "edmarkey", "katiehill"],
               "examples/speech/speech_male.wav"),
    "report": (["french", "speech/2_scott_0_103_103_28s.wav", "speech/audio3_20sec.wav"],
               ["speech/00083.wav", "speech/jfk.flac", "speech/RD_Radio31_000.wav", "speech/RD_Radio34_002.wav",
                "speech/chinese_news.wav", "speech/japanese.wav"],
               "examples/speech/speech_female.wav"),
}
CONDITIONS = ("clean", "noise20", "telephone")


@dataclass(frozen=True)
class Conversation:
    """Two sides on one timeline: ``own`` (this head's speech) and ``heard`` (the other's), both at
    :data:`SR`; ``spans`` the other's turns (start, end) in seconds."""

    name: str
    voices: str            # "one voice" or "several voices"
    condition: str         # "clean" or a degradation of the heard side
    own: Audio
    heard: Audio
    spans: tuple[tuple[float, float], ...]

    @property
    def heard_s(self) -> float:
        return float(sum(b - a for a, b in self.spans))


def turns(x: np.ndarray, *, target_s: float = TURN_S) -> list[np.ndarray]:
    """``x`` (at :data:`SR`) cut into turns of about ``target_s`` at its quietest 50 ms near each cut."""
    hop = SR // 20
    e = np.array([np.mean(x[i:i + hop] ** 2) for i in range(0, max(0, len(x) - hop), hop)])
    cuts, at = [0], 0
    while at + int(1.5 * target_s * SR) < len(x):
        lo, hi = (at + int(0.75 * target_s * SR)) // hop, (at + int(1.25 * target_s * SR)) // hop
        at = (lo + int(np.argmin(e[lo:hi]))) * hop
        cuts.append(at)
    cuts.append(len(x))
    return [x[a:b] for a, b in zip(cuts[:-1], cuts[1:]) if b - a > SR // 2]


def arrange(own_turns: list[np.ndarray], heard_turns: list[np.ndarray], *, seed: int = 0):
    """(own, heard, spans): A's turns with B's spread between them (A first, B last)."""
    rng = np.random.default_rng(seed)
    groups = np.array_split(np.arange(len(heard_turns)), max(1, len(own_turns)))
    own, heard, spans, t = [], [], [], 0
    for k, group in enumerate(groups):
        parts = ([("a", own_turns[k])] if k < len(own_turns) else []) + [("b", heard_turns[i]) for i in group]
        for who, x in parts:
            z = np.zeros(len(x), np.float32)
            own.append(x if who == "a" else z)
            heard.append(z if who == "a" else x)
            if who == "b":
                spans.append((t / SR, (t + len(x)) / SR))
            gap = np.zeros(int(rng.uniform(0.4, 0.9) * SR), np.float32)
            own += [gap]
            heard += [gap]
            t += len(x) + len(gap)
    return np.concatenate(own), np.concatenate(heard), tuple(spans)


class _Voices:
    """Audio by speaker: the corpus's recordings of a speaker joined, or a shared data file."""

    def __init__(self, corpus: Path | None, shared: Path | None, repository: Path):
        from ...io import load_audio

        self._load, self.shared, self.repository = load_audio, shared, repository
        self.by_speaker: dict[str, list[Path]] = {}
        if corpus is not None:
            from ...corpus import Corpus

            for e in Corpus.load(corpus).entries:
                self.by_speaker.setdefault(e.speaker, []).append(Path(corpus) / e.audio)

    def __call__(self, name: str) -> np.ndarray | None:
        if name.startswith("examples/"):
            paths = [self.repository / name]
        elif "/" in name:
            paths = [self.shared / name] if self.shared is not None else []
        else:
            paths = self.by_speaker.get(name, [])
        paths = [p for p in paths if p.exists()]
        if not paths:
            return None
        return np.concatenate([self._load(p, sample_rate=SR).samples.astype(np.float32) for p in paths])


def build_conversations(set_name: str, *, corpus: Path | None, shared: Path | None,
                        conditions=CONDITIONS, repository: Path | None = None) -> tuple[list[Conversation], list[str]]:
    """The conversations of a voice set (:data:`VOICE_SETS`) under ``conditions``, and a note for each
    voice that is not on disk (a missing corpus or shared data folder leaves its voices out)."""
    from .speech_set import repository_root

    if set_name not in VOICE_SETS:
        raise ParameterError(f"unknown set of conversations {set_name!r}; expected one of {', '.join(VOICE_SETS)}")
    for c in conditions:
        check_degradation(c)  # an unknown name fails before any work
    one, several, own_name = VOICE_SETS[set_name]
    voices = _Voices(corpus, shared, repository or repository_root())
    own_x = voices(own_name)
    if own_x is None:
        raise FormatError(f"this head's voice {own_name} is not in the repository; expected the bundled examples")
    own_turns = turns(own_x, target_s=len(own_x) / SR / OWN_TURNS * 0.999)[:OWN_TURNS]
    missing, plans = [], []
    for name in one:
        x = voices(name)
        if x is None:
            missing.append(f"{name}: not found")
            continue
        plans.append((f"{Path(name).stem} alone", "one voice", turns(x)[:int(HEARD_MAX_S // TURN_S)]))
    several_turns = []
    for name in several:
        x = voices(name)
        if x is None:
            missing.append(f"{name}: not found")
            continue
        several_turns += turns(x)[:2]
    several_turns = several_turns[:int(HEARD_MAX_S // TURN_S) + 1]
    if several_turns:
        plans.append((f"{len(several_turns)} turns of several voices", "several voices", several_turns))
    out = []
    for k, (name, kind, heard_turns) in enumerate(plans):
        own, heard, spans = arrange(own_turns, heard_turns, seed=k)
        for c in conditions:
            h = degrade(Audio(heard, SR), c)
            out.append(Conversation(name, kind, c, Audio(own, SR), h, spans))
    return out, missing


__all__ = ["Conversation", "VOICE_SETS", "CONDITIONS", "build_conversations", "turns", "arrange", "SR"]
