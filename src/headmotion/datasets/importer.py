"""Import a dataset folder (or any list of speech + motion pairs) as a corpus manifest.

Pairs are checked in parallel (joblib threads: the work is reading file headers and small motion
arrays).  Recordings whose lengths differ beyond the trimming rule are refused and listed with
both lengths; with ``strict`` any refusal stops the import and nothing is written.  The manifest
is written atomically (:func:`headmotion.corpus.Corpus.save`), extending an existing one."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from ..errors import HeadMotionError, ParameterError
from .layouts import DatasetItem, scan_amass, scan_beat2
from .pairs import PairCheck, check_pair

LAYOUTS = ("beat2", "amass")


@dataclass
class ImportSummary:
    """What an import did: the recordings accepted (with their checks), those refused (with the
    reason) and the problems met while scanning the folder."""

    manifest: Path | None
    accepted: list[tuple[DatasetItem, PairCheck]] = field(default_factory=list)
    refused: list[tuple[DatasetItem, str]] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)

    @property
    def minutes(self) -> float:
        return sum(min(c.audio_s, c.motion_s) for _, c in self.accepted) / 60.0

    @property
    def trimmed(self) -> list[tuple[DatasetItem, PairCheck]]:
        return [(it, c) for it, c in self.accepted if c.trimmed_s > 0]


def _check(item: DatasetItem):
    try:
        return check_pair(item.audio, item.motion, recording=item.recording)
    except HeadMotionError as exc:
        return str(exc)


def import_items(items: list[DatasetItem], output, *, task: str = "speech", jobs: int = 1, strict: bool = False,
                 progress: Callable[[int, int], None] | None = None) -> ImportSummary:
    """Check every pair and write (or extend) ``output/corpus.csv`` with the accepted ones.

    Parameters
    ----------
    items : list of DatasetItem
    output : path-like
        The corpus folder; created if needed.  An existing manifest is extended (recording ids must
        stay unique).
    task : str
        The task label written for every recording.
    jobs : int
        Pairs checked at once (threads).
    strict : bool
        Refuse the whole import when any pair is refused.
    progress : callable(done, total), optional

    Returns
    -------
    ImportSummary
    """
    from joblib import Parallel, delayed

    from ..corpus import MANIFEST, Corpus, CorpusEntry

    if not items:
        raise ParameterError("no recordings to import (no motion file has speech of the same name)")
    output = Path(output)
    summary = ImportSummary(manifest=None)
    results = []
    step = max(1, jobs * 4)
    for start in range(0, len(items), step):
        batch = items[start:start + step]
        results += Parallel(n_jobs=max(1, int(jobs)), prefer="threads")(delayed(_check)(it) for it in batch)
        if progress is not None:
            progress(len(results), len(items))
    for item, res in zip(items, results):
        if isinstance(res, PairCheck):
            summary.accepted.append((item, res))
        else:
            summary.refused.append((item, res))
    if strict and summary.refused:
        raise ParameterError(f"{len(summary.refused)} recording(s) refused, nothing written (without --strict the "
                             f"others are imported); first: {summary.refused[0][1]}")
    if not summary.accepted:
        raise ParameterError(f"every recording was refused; first: {summary.refused[0][1]}")
    existing = Corpus.load(output).entries if (output / MANIFEST).exists() else ()
    entries = list(existing) + [CorpusEntry(it.recording, it.speaker, task, it.audio.resolve(), it.motion.resolve(),
                                            split=it.split) for it, _ in summary.accepted]
    output.mkdir(parents=True, exist_ok=True)
    summary.manifest = Corpus(root=output, entries=entries).save(output)
    return summary


def import_dataset(layout: str, root, output, *, audio_dir=None, speaker: str | None = None, split_file=None,
                   additional: bool = False, jobs: int = 1, strict: bool = False,
                   progress: Callable[[int, int], None] | None = None) -> ImportSummary:
    """Scan ``root`` in the given layout (:data:`LAYOUTS`) and import it (:func:`import_items`).

    ``audio_dir``, ``speaker`` and ``split_file`` are for the ``amass`` layout; ``additional`` for
    ``beat2`` (take the split's ``additional`` recordings as training data)."""
    if layout == "beat2":
        if audio_dir is not None or speaker is not None or split_file is not None:
            raise ParameterError("--audio, --speaker and --split-file apply to the amass layout; BEAT2 names its own")
        items, problems = scan_beat2(Path(root), additional=additional)
    elif layout == "amass":
        items, problems = scan_amass(Path(root), audio_dir, speaker=speaker, split_file=split_file)
    else:
        raise ParameterError(f"unknown dataset layout {layout!r}; expected one of {', '.join(LAYOUTS)}")
    summary = import_items(items, output, jobs=jobs, strict=strict, progress=progress)
    summary.problems = problems
    return summary


__all__ = ["LAYOUTS", "ImportSummary", "import_items", "import_dataset"]
