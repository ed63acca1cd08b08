"""Recordings and corpora on disk; splits by recording (thesis §3.3, §3.5, §5.9; paper §4.1).

A corpus is a directory holding ``corpus.csv`` with the columns
``recording,speaker,task,audio,motion`` and optionally ``split``, ``speaking`` (a per-frame or
interval annotation of when the target speaker talks, see :mod:`headmotion.features.vad`) and
``fps`` (the motion file's frame rate, overriding the one the file states or implies, e.g. for
an OpenFace CSV of an image sequence or a file with a wrong rate) and ``source`` (where the
recording came from — a dataset, a channel, a studio — for leaving whole sources out).
Paths are relative to the directory.  Audio and motion may be in any supported format.

A :class:`Recording` pairs one take's audio (resampled to the corpus sample rate, 16 kHz by
default as in thesis §3.4) with its head motion, trimmed to the shorter track within the rule of
:func:`headmotion.align.recording_tolerance_s` (at most 1 s and 2 %; the seconds cut from each
track are in ``Recording.meta["trimmed"]``).

Splits are always by recording, never by frame: :func:`leave_one_out` (thesis §5.9) and
:func:`paper_split` (paper §4.1: per subject 6 recordings train, 2 validation, 2 test; with fewer
recordings the documented fallback in its docstring).
"""

from __future__ import annotations

import csv
import io as _io
from collections import OrderedDict
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from .align import align_tracks, recording_tolerance_s
from .errors import FormatError, HeadMotionError, ParameterError
from .types import Audio, Motion

MANIFEST = "corpus.csv"
REQUIRED_COLUMNS = ("recording", "speaker", "task", "audio", "motion")
OPTIONAL_COLUMNS = ("split", "speaking", "fps", "source")
DEFAULT_SAMPLE_RATE = 16000
RECORDINGS_KEPT = 64  # recordings a corpus on disk keeps loaded (their speech is decoded when read)


@dataclass(frozen=True, eq=False)
class Recording:
    """One take: a speaker's speech and head motion, aligned.

    Attributes
    ----------
    id, speaker, task : str
    audio : Audio
    motion : Motion
    speaking : np.ndarray [shape=(T,), dtype=bool] or None
        True on motion frames where the target speaker speaks (paper §4.2); ``None`` means not
        annotated: :meth:`speaking_mask` then estimates it from the audio.
    split : str or None  ("train", "valid", "test") when the manifest says so.
    """

    id: str
    speaker: str
    task: str
    audio: Audio
    motion: Motion
    speaking: np.ndarray | None = None
    split: str | None = None
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.speaking is not None:
            s = np.asarray(self.speaking, dtype=bool)
            if s.shape != (len(self.motion),):
                raise ParameterError(
                    f"recording {self.id!r}: speaking mask has shape {s.shape}, expected "
                    f"({len(self.motion)},) to match the motion"
                )
            object.__setattr__(self, "speaking", s)

    @classmethod
    def aligned(cls, id: str, speaker: str, task: str, audio: Audio, motion: Motion, **kw) -> "Recording":
        """Build a recording after trimming audio and motion to a common length (within tolerance)."""
        audio, motion = align_tracks(audio, motion, names=(f"{id} audio", f"{id} motion"))
        return cls(id=id, speaker=speaker, task=task, audio=audio, motion=motion, **kw)

    @property
    def duration(self) -> float:
        return self.motion.duration

    def speaking_mask(self) -> np.ndarray:
        """Per motion frame, True where the speaker speaks: the annotation, else estimated."""
        if self.speaking is not None:
            return self.speaking
        from .features.vad import speaking_mask

        return speaking_mask(self.audio, fps=self.motion.fps, n_frames=len(self.motion))


@dataclass(frozen=True)
class CorpusEntry:
    """One manifest row: where a recording's files are."""

    recording: str
    speaker: str
    task: str
    audio: Path
    motion: Path
    split: str | None = None
    speaking: Path | None = None
    fps: float | None = None
    #: where the recording came from (a dataset, a channel, a studio): recordings of one source share
    #: its microphones, rooms and speakers; ``evaluate --protocol sources`` holds out one at a time
    source: str | None = None


class Corpus(Sequence[Recording]):
    """An ordered collection of recordings, from a directory or built in memory.

    Recordings from disk are loaded on first access; the corpus keeps the :data:`RECORDINGS_KEPT`
    most recently used, and their speech is a :class:`~headmotion.stored_audio.StoredAudio`
    (decoded when read, a bounded cache of recent ones), so that iterating a corpus of tens of
    hours, or holding a list of all its recordings, does not hold its speech in memory.
    """

    def __init__(self, recordings: Sequence[Recording] = (), *, root: Path | None = None,
                 entries: Sequence[CorpusEntry] = (), sample_rate: int = DEFAULT_SAMPLE_RATE):
        self.root = None if root is None else Path(root)
        self.sample_rate = int(sample_rate)
        if recordings and entries:
            raise ParameterError("give either recordings or manifest entries, not both")
        self._entries: tuple[CorpusEntry, ...] = tuple(entries)
        self._cache: OrderedDict[int, Recording] = OrderedDict()
        if recordings:
            self._entries = tuple(
                CorpusEntry(r.id, r.speaker, r.task, Path(), Path(), r.split) for r in recordings
            )
            self._cache = OrderedDict(enumerate(recordings))
        self._given = bool(recordings)  # recordings built in memory are all kept
        ids = [e.recording for e in self._entries]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ParameterError(f"recording ids must be unique; repeated: {dup}")

    # -- construction ------------------------------------------------------------------------
    @classmethod
    def load(cls, root, *, sample_rate: int = DEFAULT_SAMPLE_RATE) -> "Corpus":
        """Read ``root/corpus.csv`` (files are loaded when first used)."""
        root = Path(root)
        manifest = root / MANIFEST if root.is_dir() else root
        if root.name == MANIFEST and not root.is_dir():
            root = root.parent
        elif not root.is_dir():
            raise FormatError(f"not a corpus directory (expected a folder containing {MANIFEST})", path=root)
        if not manifest.exists():
            raise FormatError(f"no {MANIFEST} in the corpus directory", path=root)
        text = manifest.read_text(encoding="utf-8-sig")
        reader = csv.DictReader(_io.StringIO(text))
        cols = reader.fieldnames or []
        missing = [c for c in REQUIRED_COLUMNS if c not in cols]
        if missing:
            raise FormatError(
                f"missing column(s) {missing}; a corpus manifest needs {list(REQUIRED_COLUMNS)}",
                path=manifest, line=1)
        entries = []
        for lineno, row in enumerate(reader, start=2):
            if not any((v or "").strip() for v in row.values()):
                continue
            for c in REQUIRED_COLUMNS:
                if not (row.get(c) or "").strip():
                    raise FormatError(f"empty value in column {c!r}", path=manifest, line=lineno)
            split = (row.get("split") or "").strip() or None
            if split is not None and split not in ("train", "valid", "test"):
                raise FormatError(f"split must be train, valid or test; got {split!r}", path=manifest, line=lineno)
            spk = (row.get("speaking") or "").strip()
            fps_s = (row.get("fps") or "").strip()
            fps = None
            if fps_s:
                try:
                    fps = float(fps_s)
                except ValueError:
                    fps = float("nan")
                if not (1.0 <= fps <= 1000.0):
                    raise FormatError(f"fps must be a number within 1–1000 (or empty); got {fps_s!r}",
                                      path=manifest, line=lineno)
            entries.append(CorpusEntry(
                recording=row["recording"].strip(), speaker=row["speaker"].strip(), task=row["task"].strip(),
                audio=Path(row["audio"].strip()), motion=Path(row["motion"].strip()), split=split,
                speaking=Path(spk) if spk else None, fps=fps,
                source=(row.get("source") or "").strip() or None))
        return cls(root=root, entries=entries, sample_rate=sample_rate)

    def save(self, root=None) -> Path:
        """Write the manifest (and, for in-memory recordings, their audio and motion files).

        In-memory recordings are written as ``<id>.wav`` and ``<id>.npz``."""
        from .io import save_audio, save_motion
        from .io.atomic import atomic_write_text

        root = Path(root) if root is not None else self.root
        if root is None:
            raise ParameterError("Corpus.save needs a directory")
        root.mkdir(parents=True, exist_ok=True)
        rows = []
        for i, e in enumerate(self._entries):
            audio_rel, motion_rel = e.audio, e.motion
            if self.root is None or root != self.root or str(e.audio) in ("", "."):
                rec = self[i]
                audio_rel, motion_rel = Path(f"{e.recording}.wav"), Path(f"{e.recording}.npz")
                save_audio(rec.audio, root / audio_rel)
                save_motion(rec.motion, root / motion_rel)
            rows.append({"recording": e.recording, "speaker": e.speaker, "task": e.task,
                         "audio": audio_rel.as_posix(), "motion": motion_rel.as_posix(),
                         "split": e.split or "", "speaking": "" if e.speaking is None else e.speaking.as_posix(),
                         "fps": "" if e.fps is None else f"{e.fps:g}", "source": e.source or ""})
        cols = list(REQUIRED_COLUMNS) + list(OPTIONAL_COLUMNS)
        if all(e.fps is None for e in self._entries):
            cols.remove("fps")  # written only when used
        if all(e.source is None for e in self._entries):
            cols.remove("source")
        buf = _io.StringIO()
        w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n", extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
        atomic_write_text(root / MANIFEST, buf.getvalue())
        return root / MANIFEST

    # -- access --------------------------------------------------------------------------------
    @property
    def entries(self) -> tuple[CorpusEntry, ...]:
        return self._entries

    @property
    def ids(self) -> list[str]:
        return [e.recording for e in self._entries]

    @property
    def speakers(self) -> list[str]:
        return sorted({e.speaker for e in self._entries})

    @property
    def tasks(self) -> list[str]:
        return sorted({e.task for e in self._entries})

    def __len__(self) -> int:
        return len(self._entries)

    def __getitem__(self, index):  # type: ignore[override]
        if isinstance(index, slice):
            return self.subset(range(len(self))[index])
        if isinstance(index, str):
            index = self.ids.index(index)
        if index < 0:
            index += len(self)
        rec = self._cache.get(index)
        if rec is None:
            rec = self._cache[index] = self._load_entry(self._entries[index])
        if self.root is not None and not self._given:  # a corpus on disk keeps its recently used ones
            self._cache.move_to_end(index)
            while len(self._cache) > RECORDINGS_KEPT:
                self._cache.popitem(last=False)
        return rec

    def __iter__(self) -> Iterator[Recording]:
        for i in range(len(self)):
            yield self[i]

    def _load_entry(self, e: CorpusEntry) -> Recording:
        """The recording, its speech a :class:`~headmotion.stored_audio.StoredAudio` (decoded
        again when read after leaving the decoded cache; the samples are those read here)."""
        from .stored_audio import StoredAudio, _samples

        rec = self._read_entry(e)
        key = (str(self.root), e.recording, str(e.audio), self.sample_rate)
        _samples(key, lambda: rec.audio.samples)  # decoded once now: the first read needs no decode
        audio = StoredAudio(partial(_read_samples, self.root, e, self.sample_rate), len(rec.audio),
                            rec.audio.sample_rate, key)
        meta = {**rec.meta, "source": {"corpus": str(self.root), "audio": str(self.root / e.audio)}}
        return Recording(rec.id, rec.speaker, rec.task, audio, rec.motion, speaking=rec.speaking,
                         split=rec.split, meta=meta)

    def _read_entry(self, e: CorpusEntry) -> Recording:
        """Decode and align one entry's files (speech held in memory)."""
        from .io import load_audio, load_motion

        base = self.root if self.root is not None else Path()
        audio = load_audio(base / e.audio, sample_rate=self.sample_rate)
        if e.fps is None:
            motion = load_motion(base / e.motion)
        else:  # the reader takes the rate when it can (files whose rate may be missing) ...
            from .io.motion import detect_format

            path = base / e.motion
            takes_fps = (path.is_file() and path.stat().st_size > 0
                         and detect_format(path) in ("openface", "livelink", "smpl", "csv"))
            motion = load_motion(path, fps=e.fps) if takes_fps else load_motion(path)  # ... else re-timed
            if motion.fps != e.fps:
                motion = motion.replace(fps=e.fps)
            motion = motion.replace(meta={**motion.meta, "fps_from": "corpus.csv"})
        before = (audio.duration, motion.duration)
        audio, motion = align_tracks(audio, motion, names=(str(e.audio), str(e.motion)),
                                     tolerance_s=recording_tolerance_s(before))
        trimmed = {"audio_s": round(before[0] - audio.duration, 3), "motion_s": round(before[1] - motion.duration, 3)}
        speaking = None
        if e.speaking is not None:
            from .features.vad import load_speaking_annotation

            speaking = load_speaking_annotation(base / e.speaking, fps=motion.fps, n_frames=len(motion))
        return Recording(e.recording, e.speaker, e.task, audio, motion, speaking=speaking, split=e.split,
                         meta={"trimmed": trimmed})

    def subset(self, indices_or_ids) -> "Corpus":
        idx = [self.ids.index(i) if isinstance(i, str) else int(i) for i in indices_or_ids]
        if self.root is not None:  # stays on disk: recordings loaded when used, the feature cache found
            c = Corpus(root=self.root, entries=[self._entries[i] for i in idx], sample_rate=self.sample_rate)
            for new, old in enumerate(idx):
                if old in self._cache:
                    c._cache[new] = self._cache[old]
            return c
        return Corpus([self[i] for i in idx], sample_rate=self.sample_rate)

    def filter(self, *, speaker: str | None = None, task: str | None = None, split: str | None = None) -> "Corpus":
        idx = [i for i, e in enumerate(self._entries)
               if (speaker is None or e.speaker == speaker) and (task is None or e.task == task)
               and (split is None or e.split == split)]
        if not idx:
            raise ParameterError(
                f"no recordings with speaker={speaker!r}, task={task!r}, split={split!r}; "
                f"speakers are {self.speakers}")
        return self.subset(idx)

    def summary(self) -> dict:
        """Speakers, tasks, recordings and minutes: what a saved model records about its data."""
        recs = list(self)
        return {
            "recordings": len(recs),
            "speakers": sorted({r.speaker for r in recs}),
            "tasks": sorted({r.task for r in recs}),
            "minutes": round(sum(r.duration for r in recs) / 60.0, 3),
            "fps": sorted({float(r.motion.fps) for r in recs}),
        }

    def __repr__(self) -> str:
        where = f" at {self.root}" if self.root else ""
        return f"Corpus({len(self)} recordings, speakers={self.speakers}{where})"


def _read_samples(root: Path, e: CorpusEntry, sample_rate: int) -> np.ndarray:
    """The aligned speech samples of entry ``e`` of the corpus at ``root`` (a StoredAudio's load)."""
    return Corpus(root=root, entries=[e], sample_rate=sample_rate)._read_entry(e).audio.samples


# -- splits ---------------------------------------------------------------------------------------
def leave_one_out(corpus: Corpus, *, per_speaker: bool = True) -> Iterator[tuple[str, Corpus, Corpus]]:
    """Leave-one-recording-out folds (thesis §5.9): yields ``(held_out_id, train, test)``.

    With ``per_speaker`` the training set holds only the held-out recording's speaker's other
    recordings (speaker-dependent models).  A speaker with a single recording gets no fold."""
    for i, e in enumerate(corpus.entries):
        others = [j for j, f in enumerate(corpus.entries)
                  if j != i and (not per_speaker or f.speaker == e.speaker)]
        if not others:
            continue
        yield e.recording, corpus.subset(others), corpus.subset([i])


def paper_split(corpus: Corpus, *, seed: int = 0) -> dict[str, str]:
    """Per speaker, assign recordings to train / valid / test as in paper §4.1 (6 / 2 / 2 of 10).

    When the manifest has a ``split`` column it is used as given.  Otherwise, per speaker, the
    recordings are shuffled with ``seed`` and split in the proportions 60 / 20 / 20 %, rounding so
    that train keeps at least one recording.  Fallbacks for few recordings: 1 recording → train
    only; 2 → train, test; 3 → train, valid, test.  Returns ``{recording_id: split}``.
    """
    if all(e.split for e in corpus.entries):
        return {e.recording: e.split for e in corpus.entries}  # type: ignore[misc]
    rng = np.random.default_rng(seed)
    out: dict[str, str] = {}
    for spk in corpus.speakers:
        ids = [e.recording for e in corpus.entries if e.speaker == spk]
        ids = [ids[i] for i in rng.permutation(len(ids))]
        n = len(ids)
        if n == 1:
            n_valid, n_test = 0, 0
        elif n == 2:
            n_valid, n_test = 0, 1
        else:
            n_test = max(1, int(round(0.2 * n)))
            n_valid = max(1, int(round(0.2 * n)))
        n_train = n - n_valid - n_test
        for k, rid in enumerate(ids):
            out[rid] = "train" if k < n_train else ("valid" if k < n_train + n_valid else "test")
    return out


def check_corpus(corpus: Corpus) -> tuple[list[dict], list[str]]:
    """Load every recording; return per-recording rows and a list of problems (never raises for
    a bad file: the problem is reported and the check goes on).

    Each row has ``recording, speaker, task, minutes, fps, speaking, trimmed_s, ok``.  A recording
    that cannot be loaded is still described from whichever of its files can be read (its motion's
    length and rate, else its speech's length); a value that no file gives is ``None``, never NaN.
    ``trimmed_s`` is the longer of the two cuts made to align speech and motion."""
    rows: list[dict] = []
    problems: list[str] = []
    for i, e in enumerate(corpus.entries):
        base = {"recording": e.recording, "speaker": e.speaker, "task": e.task}
        try:
            r = corpus[i]
        except HeadMotionError as exc:
            problems.append(f"{e.recording}: {exc}")
            rows.append({**base, **_describe_files(corpus, e), "speaking": None, "trimmed_s": None, "ok": False})
            continue
        mask = r.speaking_mask()
        trimmed = r.meta.get("trimmed") or {}
        rows.append({**base, "minutes": r.duration / 60.0, "fps": r.motion.fps,
                     "speaking": float(np.mean(mask)) if len(mask) else 0.0,
                     "trimmed_s": max(trimmed.values(), default=0.0), "ok": True})
        if not mask.any():
            problems.append(f"{r.id}: no speaking frames detected")
    return rows, problems


def _describe_files(corpus: Corpus, e: CorpusEntry) -> dict:
    """Minutes and frame rate of an entry that did not load, from the files that can be read."""
    from .io import load_motion
    from .io.audio_blocks import audio_duration

    base = corpus.root if corpus.root is not None else Path()
    try:
        m = load_motion(base / e.motion) if e.fps is None else load_motion(base / e.motion).replace(fps=e.fps)
        return {"minutes": m.duration / 60.0, "fps": float(m.fps)}
    except HeadMotionError:
        pass
    seconds = audio_duration(base / e.audio) if (base / e.audio).is_file() else float("nan")
    return {"minutes": seconds / 60.0 if np.isfinite(seconds) else None, "fps": None}


__all__ = ["Recording", "Corpus", "CorpusEntry", "leave_one_out", "paper_split", "check_corpus", "MANIFEST"]
