"""The speech-only set: users' voices with no recorded head, each with its kind.

The files ``headmotion evaluate-speech --speech-set SHARED_DATA`` scores
(docs/decisions/follow-any-voice.md): the 8 files of ``SHARED_DATA/speech`` that are not the speech
of a corpus recording (``video_retalking_1.wav`` is), the ZEGGS actor's speech
(``SHARED_DATA/mocap_speech/zeggs``) when it is there, and the 3 examples bundled with the
repository (``examples/speech``).  Each file's *kind* says what makes it unlike the corpus:

* ``broadcast`` — radio, news or a recorded talk in English;
* ``phone-like`` — a narrow band (the JFK archive: 99.5 % of its power under 3.1 kHz, little
  under 300 Hz);
* ``language`` — not English (Japanese, Mandarin);
* ``studio`` — a speech-and-motion studio take in English (MP3-coded in one case);
* ``synthetic`` — espeak-ng speech (the bundled examples).

    >>> files = speech_set_files(Path("../shared/data"))     # [(path, name), …] present on disk
    >>> describe("jfk")                                       # ("phone-like", "English")
"""

from __future__ import annotations

from pathlib import Path

from ...errors import FormatError

#: file → (kind, language, what it is); the path is relative to the shared data folder, or to
#: the repository for ``examples/``
SPEECH_SET = {
    "speech/jfk.flac": ("phone-like", "English", "1961 address, band-limited archive (openai/whisper)"),
    "speech/00083.wav": ("broadcast", "English", "a recorded talk, 16 kHz (LiveSpeechPortraits)"),
    "speech/RD_Radio31_000.wav": ("broadcast", "English", "radio show (SadTalker)"),
    "speech/RD_Radio34_002.wav": ("broadcast", "English", "radio show (SadTalker)"),
    "speech/chinese_news.wav": ("language", "Mandarin", "television news (SadTalker)"),
    "speech/japanese.wav": ("language", "Japanese", "read speech (SadTalker)"),
    "speech/audio3_20sec.wav": ("studio", "English", "speech-gesture studio take (Trinity)"),
    "speech/2_scott_0_103_103_28s.wav": ("studio", "English", "speech-gesture studio take, MP3-coded (BEAT)"),
    "mocap_speech/zeggs/067_Speech_2_x_1_0.wav": ("studio", "English", "the ZEGGS actor's take (mocap studio)"),
    "examples/speech/speech_male.wav": ("synthetic", "English", "espeak-ng en-us (bundled)"),
    "examples/speech/speech_female.wav": ("synthetic", "English", "espeak-ng en+f3 (bundled)"),
    "examples/speech/short.wav": ("synthetic", "English", "espeak-ng en-us, 2.8 s (bundled)"),
}
#: the files that are not there without the shared data's optional parts
OPTIONAL = ("mocap_speech/zeggs/067_Speech_2_x_1_0.wav",)


def repository_root() -> Path:
    """The repository this package is checked out in (``examples/`` lives there)."""
    return Path(__file__).resolve().parents[4]


def speech_set_files(shared: Path, *, repository: Path | None = None) -> tuple[list[Path], list[str]]:
    """The speech-only set's files found on disk, and a note for each one that is not.

    Parameters
    ----------
    shared : the shared data folder (``../shared/data``: ``speech/``, ``mocap_speech/``)
    repository : where ``examples/`` is (default: the checkout this package runs from)

    Returns
    -------
    (paths, missing) — the paths in :data:`SPEECH_SET`'s order, and a line per file not found

    Raises
    ------
    FormatError — ``shared`` is not a folder with ``speech/`` in it
    """
    shared = Path(shared)
    if not (shared / "speech").is_dir():
        raise FormatError("the speech-only set needs the shared data folder (with speech/ in it)", path=shared)
    repo = Path(repository) if repository is not None else repository_root()
    paths, missing = [], []
    for rel in SPEECH_SET:
        p = (repo if rel.startswith("examples/") else shared) / rel
        if p.is_file():
            paths.append(p)
        else:
            missing.append(f"{rel} not found under {p.parent}" + (" (optional)" if rel in OPTIONAL else ""))
    return paths, missing


def describe(name: str) -> tuple[str, str]:
    """``(kind, language)`` of a file of the set by its stem or file name; ``("–", "–")`` for others."""
    for rel, (kind, lang, _) in SPEECH_SET.items():
        p = Path(rel)
        if name in (p.stem, p.name, rel):
            return kind, lang
    return "–", "–"


__all__ = ["SPEECH_SET", "OPTIONAL", "speech_set_files", "describe", "repository_root"]
