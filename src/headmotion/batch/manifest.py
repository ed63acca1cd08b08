"""What a batch has written, so that a second run skips what is up to date.

The output folder holds ``.headmotion-synth.jsonl``: one JSON line per input written, appended
(and flushed) as each one finishes, so an interrupted run keeps what it finished.  A line holds
the output's name, the input's size, modification time and SHA-256, the key of the model and
options (:func:`options_key`) and each output file's size and modification time.  An input is up
to date when its line has the same options key, every output is still there as it was written,
and the input is the same: the same size and modification time, or else the same SHA-256 (a file
copied or touched but unchanged is not made again).  The latest line of a name wins; the file is
rewritten without the superseded lines when a run starts.  A damaged line is ignored (that input
is made again).
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

from ..io.atomic import atomic_write_text

MANIFEST_NAME = ".headmotion-synth.jsonl"


def file_digest(path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def options_key(settings: dict) -> str:
    """A short key of everything besides the input that decides the outputs (model identity,
    seed, controls, format, software version): SHA-256 of their canonical JSON."""
    text = json.dumps(settings, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def _stat(path: Path) -> list[int]:
    st = os.stat(path)
    return [st.st_size, st.st_mtime_ns]


class Manifest:
    """The records of one output folder (see the module docstring)."""

    def __init__(self, out_dir):
        self.out_dir = Path(out_dir)
        self.path = self.out_dir / MANIFEST_NAME
        self.records: dict[str, dict] = {}
        self._lines = 0
        self._fh = None
        try:
            text = self.path.read_text(encoding="utf-8")
        except (FileNotFoundError, UnicodeDecodeError, IsADirectoryError):
            return
        for line in text.splitlines():
            self._lines += 1
            try:
                rec = json.loads(line)
                self.records[str(rec["name"])] = rec
            except (ValueError, KeyError, TypeError):
                continue

    def up_to_date(self, name: str, source: Path, key: str) -> bool:
        """Whether the outputs recorded for ``name`` stand for ``source`` under ``key``."""
        rec = self.records.get(name)
        if rec is None or rec.get("key") != key:
            return False
        try:
            for out_name, size, mtime in rec["outputs"]:
                if _stat(self.out_dir / out_name) != [size, mtime]:
                    return False
            now = _stat(source)
            if now == [rec["size"], rec["mtime_ns"]]:
                return True
            if now[0] != rec["size"] or file_digest(source) != rec["sha256"]:
                return False
        except (OSError, ValueError, TypeError, KeyError):
            return False
        rec["size"], rec["mtime_ns"] = now  # the same bytes, touched: remembered for next time
        self._append(rec)
        return True

    def record(self, name: str, source: Path, key: str, source_stat, sha256: str, outputs) -> None:
        """Append the line of a finished input (``source_stat``: its [size, mtime_ns] when read)."""
        rec = {"name": name, "source": str(source), "size": int(source_stat[0]), "mtime_ns": int(source_stat[1]),
               "sha256": sha256, "key": key,
               "outputs": [[Path(p).relative_to(self.out_dir).as_posix(), *_stat(p)] for p in outputs]}
        self.records[name] = rec
        self._append(rec)

    def compact(self) -> None:
        """Rewrite the file with one line per name when it holds superseded or damaged lines."""
        if self._lines > len(self.records):
            self.close()  # appends go to the new file, not to the one it replaces
            atomic_write_text(self.path, "".join(json.dumps(r) + "\n" for r in self.records.values()))
            self._lines = len(self.records)

    def _append(self, rec: dict) -> None:
        if self._fh is None:
            self.out_dir.mkdir(parents=True, exist_ok=True)
            self._fh = open(self.path, "a", encoding="utf-8")  # noqa: SIM115 - held for the run, closed by close()
        self._fh.write(json.dumps(rec) + "\n")
        self._fh.flush()
        self._lines += 1

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None


__all__ = ["MANIFEST_NAME", "Manifest", "file_digest", "options_key"]
