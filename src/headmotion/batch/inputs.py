"""Which speech files a batch reads, and the motion file each one becomes.

An input is a file, a folder (searched recursively for audio) or ``@LIST`` (a text file naming
one file or folder per line; blank lines and lines starting with ``#`` are skipped; relative
entries are read from the list's folder).  Names and sub-folders of the outputs mirror the
inputs: ``voice/en/line1.wav`` found in the folder ``voice`` becomes ``OUT/en/line1.bvh``; a file
given by itself becomes ``OUT/<its name>.bvh``; a list's entries keep their path relative to the
list's folder (``OUT/en/line1.bvh`` for the entry ``en/line1.wav``), an entry outside that folder
its name.  With ``samples > 1`` each input makes ``NAME_1``, ``NAME_2``, … as ``headmotion synth``
does.  Two inputs that would write the same output are refused before anything is written.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import ParameterError

#: the motion formats a batch writes (``--format``), each the extension of its files
BATCH_FORMATS = ("bvh", "glb", "gltf", "csv", "json", "npz")

#: the files a folder search takes as speech (other files in the folders are left alone); a
#: video is taken when named as a file or in a list, as ``headmotion synth`` takes one
AUDIO_EXTENSIONS = frozenset({".wav", ".flac", ".ogg", ".oga", ".aiff", ".aif", ".mp3", ".m4a", ".aac", ".opus",
                              ".wma", ".mka"})


@dataclass(frozen=True)
class Job:
    """One input and the files it becomes (``outputs``: one per sample; ``name``: the first
    output relative to the output folder, POSIX style — the input's key in the manifest)."""

    source: Path
    outputs: tuple
    name: str


def _speech_in(folder: Path) -> list[Path]:
    found = []
    for root, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        found += [Path(root) / f for f in sorted(files)
                  if not f.startswith(".") and Path(f).suffix.lower() in AUDIO_EXTENSIONS]
    return found


def _list_entries(list_file: Path) -> list[Path]:
    try:
        text = list_file.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise ParameterError(f"{list_file}: list file not found (an @LIST input names one speech file or folder "
                             "a line)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ParameterError(f"{list_file}: cannot read the list file ({exc})") from None
    base = list_file.parent
    out = []
    for line in text.splitlines():
        entry = line.strip()
        if entry and not entry.startswith("#"):
            p = Path(entry).expanduser()
            out.append(p if p.is_absolute() else base / p)
    return out


def _relative(path: Path, base: Path | None) -> Path:
    """``path`` relative to ``base`` when it lies inside it, else its name."""
    if base is not None:
        try:
            return path.relative_to(base)
        except ValueError:
            pass
    return Path(path.name)


def _expand(arg: Path, base: Path | None) -> list[tuple[Path, Path]]:
    """(input file, its name relative to the output folder) for one file or folder."""
    if arg.is_dir():
        return [(p, p.relative_to(arg)) for p in _speech_in(arg)]
    return [(arg, _relative(arg, base))]  # a missing file is reported when it is read, not here


def find_inputs(inputs) -> list[tuple[Path, Path]]:
    """Every speech file the inputs name, with its name relative to the output folder (order:
    as given, folders sorted)."""
    pairs: list[tuple[Path, Path]] = []
    for item in inputs:
        text = str(item)
        if text.startswith("@"):
            list_file = Path(text[1:]).expanduser()
            for entry in _list_entries(list_file):
                pairs += _expand(entry, list_file.parent)
        else:
            pairs += _expand(Path(item), None)
    return pairs


def output_paths(out_dir: Path, rel: Path, fmt: str, samples: int) -> tuple:
    """The files one input becomes (``headmotion synth``'s ``OUT_k`` names for samples)."""
    stem = out_dir / rel.with_suffix("")
    if samples == 1:
        return (stem.with_name(f"{stem.name}.{fmt}"),)
    return tuple(stem.with_name(f"{stem.name}_{k + 1}.{fmt}") for k in range(samples))


def plan_jobs(inputs, out_dir, fmt: str, samples: int = 1) -> list[Job]:
    """The jobs of a batch: every input file and its outputs under ``out_dir``.

    Raises :class:`~headmotion.errors.ParameterError` for an unknown format, no input at all, or
    two inputs that would write the same file (both named)."""
    if fmt not in BATCH_FORMATS:
        raise ParameterError(f"--format must be one of {', '.join(BATCH_FORMATS)}; got {fmt!r}")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise ParameterError(f"{out_dir}: the output of several inputs is a folder; this is a file")
    jobs, seen = [], {}
    for source, rel in find_inputs(inputs):
        outs = output_paths(out_dir, rel, fmt, samples)
        name = outs[0].relative_to(out_dir).as_posix()
        key = name.lower()  # case-insensitive file systems would write both to one file
        if key in seen:
            raise ParameterError(f"{seen[key]} and {source} would both be written to {outs[0]}; rename one or "
                                 "run them into different folders")
        seen[key] = source
        jobs.append(Job(source, outs, name))
    if not jobs:
        raise ParameterError("no speech files found in the inputs (folders are searched for "
                             f"{', '.join(sorted(AUDIO_EXTENSIONS))})")
    return jobs


__all__ = ["AUDIO_EXTENSIONS", "BATCH_FORMATS", "Job", "find_inputs", "output_paths", "plan_jobs"]
