"""Where the speech, the motion and the split of each public corpus layout are.

BEAT2 (Liu et al., EMAGE, CVPR 2024), as released: ``ROOT/smplxflame_30/<id>.npz`` (SMPL-X
``poses`` of width 165, ``mocap_frame_rate`` 30), ``ROOT/wave16k/<id>.wav`` (16 kHz) and
``ROOT/train_test_split.csv`` with columns ``id,type`` (``train``, ``val``, ``test`` or
``additional``).  Ids are ``<speaker number>_<name>_<...>``; the speaker is the name.

AMASS-style: SMPL-X / SMPL-H ``.npz`` takes anywhere below ``ROOT`` (AMASS nests them as
``SUBSET/SUBJECT/take.npz``), each with its speech in an audio folder, at the same relative path
(``SUBSET/SUBJECT/take.wav``) or else by the same stem; the speaker is the take's parent folder.  A split file in BEAT2's ``id,type`` form is optional.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

from ..errors import FormatError, ParameterError

AUDIO_EXT = (".wav", ".flac", ".ogg", ".mp3", ".m4a")
#: a split file's ``type`` → the corpus manifest's ``split``
SPLIT_NAMES = {"train": "train", "val": "valid", "valid": "valid", "test": "test", "additional": "train"}


@dataclass(frozen=True)
class DatasetItem:
    """One recording found in a dataset folder."""

    recording: str
    speaker: str
    audio: Path
    motion: Path
    split: str | None = None


def read_split_file(path: Path) -> dict[str, str]:
    """``id → type`` from a BEAT2-style ``train_test_split.csv`` (types as written)."""
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise FormatError(f"cannot read the split file ({exc.strerror})", path=path) from None
    reader = csv.DictReader(text.splitlines())
    if not reader.fieldnames or not {"id", "type"} <= set(reader.fieldnames):
        raise FormatError(f"a split file needs the columns id,type; got {reader.fieldnames}", path=path, line=1)
    out = {}
    for lineno, row in enumerate(reader, start=2):
        rid, kind = (row.get("id") or "").strip(), (row.get("type") or "").strip()
        if not rid:
            continue
        if kind not in SPLIT_NAMES:
            raise FormatError(f"split type must be one of {sorted(SPLIT_NAMES)}; got {kind!r}", path=path, line=lineno)
        out[rid] = kind
    return out


def _audio_by_stem(folder: Path) -> dict[str, Path]:
    return {p.stem: p for p in sorted(folder.rglob("*")) if p.suffix.lower() in AUDIO_EXT and p.is_file()}


def scan_beat2(root: Path, *, additional: bool = False) -> tuple[list[DatasetItem], list[str]]:
    """The recordings of a BEAT2 folder and the problems found (unpaired files, ids missing from
    the split file).  ``additional`` takes the split's ``additional`` takes as training data (the
    BEAT2 loaders' option); by default they are left out, as the benchmark's split does."""
    root = Path(root)
    motion_dir, audio_dir, split_path = root / "smplxflame_30", root / "wave16k", root / "train_test_split.csv"
    for need in (motion_dir, audio_dir):
        if not need.is_dir():
            raise FormatError(f"not a BEAT2 folder: {need.name}/ is missing (expected smplxflame_30/ and wave16k/)",
                              path=root)
    split = read_split_file(split_path) if split_path.is_file() else {}
    audio = _audio_by_stem(audio_dir)
    items, problems = [], []
    for m in sorted(motion_dir.glob("*.npz")):
        rid = m.stem
        parts = rid.split("_")
        if len(parts) < 2 or not parts[1]:
            problems.append(f"{m}: not a BEAT2 name (<number>_<speaker>_...); skipped")
            continue
        if rid not in audio:
            problems.append(f"{m}: no speech {rid}.wav in {audio_dir}; skipped")
            continue
        kind = split.get(rid)
        if split and kind is None:
            problems.append(f"{rid}: not in {split_path.name}; imported without a split")
        if kind == "additional" and not additional:
            continue
        items.append(DatasetItem(rid, parts[1], audio[rid], m, SPLIT_NAMES.get(kind) if kind else None))
    return items, problems


def scan_amass(root: Path, audio_dir: Path | None, *, speaker: str | None = None,
               split_file: Path | None = None) -> tuple[list[DatasetItem], list[str]]:
    """The takes of an AMASS-style folder that have speech of the same stem in ``audio_dir``
    (default: ``root`` itself); recording ids are the take's path below ``root`` joined by ``_``."""
    from ..io.motion import sniff_npz

    root = Path(root)
    if not root.is_dir():
        raise ParameterError(f"{root}: not a folder")
    audio_dir = Path(audio_dir) if audio_dir is not None else root
    if not audio_dir.is_dir():
        raise ParameterError(f"{audio_dir}: the audio folder does not exist")
    split = read_split_file(split_file) if split_file is not None else {}
    audio = _audio_by_stem(audio_dir)
    items, problems = [], []
    for m in sorted(root.rglob("*.npz")):
        try:
            if sniff_npz(m) != "smpl":
                continue
        except FormatError as exc:
            problems.append(f"{exc}; skipped")
            continue
        rel = m.relative_to(root).with_suffix("")
        same_place = [audio_dir / rel.with_suffix(ext) for ext in AUDIO_EXT if (audio_dir / rel.with_suffix(ext)).is_file()]
        speech = same_place[0] if same_place else audio.get(m.stem)
        if speech is None:
            problems.append(f"{m}: no speech {rel}.wav (or the stem {m.stem!r}) in {audio_dir}; skipped")
            continue
        rid = "_".join(rel.parts)
        kind = split.get(rid, split.get(m.stem))
        spk = speaker or (m.parent.name if m.parent != root else m.stem)
        items.append(DatasetItem(rid, spk, speech, m, SPLIT_NAMES.get(kind) if kind else None))
    return items, problems


__all__ = ["DatasetItem", "read_split_file", "scan_beat2", "scan_amass", "SPLIT_NAMES", "AUDIO_EXT"]
