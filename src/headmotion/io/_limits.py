"""Checks every reader makes before it trusts a file.

The seeds are silent on damaged files; what is chosen here:

* **rates** must be finite and within :data:`FPS_RANGE` (1–1000 frames/s) for motion and
  :data:`SAMPLE_RATE_RANGE` (1 kHz–384 kHz) for audio (:func:`check_fps`);
* **declared counts and sizes** are parsed with :func:`parse_count` (digits only, at most
  :data:`MAX_COUNT`) and compared with what the file holds before anything is allocated;
* **text** files are read whole only below :data:`MAX_TEXT_BYTES`; CSV fields stay within the
  ``csv`` module's limit (131 072 characters), and its ``csv.Error`` becomes a
  :class:`~headmotion.errors.FormatError` with the line (:func:`csv_rows`);
* **JSON** nesting is measured before parsing (:func:`load_json`, at most :data:`MAX_JSON_DEPTH`
  levels, so the recursive C parser cannot overflow the stack) and integers longer than
  :data:`MAX_INT_DIGITS` digits are refused (Python's own limit is 4300 and raises ValueError);
* **npz** archives (motion ``.npz``, a model's ``arrays.npz``) are opened with zipfile; each
  member's declared uncompressed size is checked against :data:`MAX_NPZ_BYTES` and each array's
  header (shape × item size) against the member's size *before* numpy allocates anything
  (:func:`load_npz_arrays`), and members are read through a reader that stops at the declared
  size, so a zip bomb cannot expand.

Libraries considered: ``defusedxml``-style wrappers do not exist for JSON/CSV/npz; ``jsonschema``
(not a dependency) for one flat object is more than needed — the checks are written here.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
import zipfile
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from ..errors import FormatError, HeadMotionError

FPS_RANGE = (1.0, 1000.0)
SAMPLE_RATE_RANGE = (1000, 384_000)
MAX_COUNT = 10**9
MAX_TEXT_BYTES = 2 << 30
MAX_JSON_DEPTH = 64
MAX_INT_DIGITS = 100
MAX_NPZ_BYTES = 4 << 30
MAX_NPZ_MEMBERS = 10_000


def check_fps(value: Any, *, path=None, line: int | None = None, what: str = "frame rate",
              error=FormatError) -> float:
    """``value`` as a float frame rate in :data:`FPS_RANGE`, else ``error`` naming it."""
    lo, hi = FPS_RANGE
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        v = math.nan
    if not (math.isfinite(v) and lo <= v <= hi):
        shown = value if isinstance(value, (int, float, str)) and len(str(value)) < 40 else "…"
        msg = f"{what} {shown!r} is not a finite rate between {lo:g} and {hi:g} frames/s"
        if error is FormatError or issubclass(error, FormatError):
            raise error(msg, path=path, line=line)
        raise error(f"{path}: {msg}" if path is not None else msg)
    return v


def parse_count(token: str, *, path=None, line: int | None = None, what: str = "count",
                maximum: int = MAX_COUNT) -> int:
    """A non-negative whole number written in the file (at most ``maximum``)."""
    t = str(token).strip()
    if not re.fullmatch(r"\+?\d{1,12}", t) or int(t) > maximum:
        shown = t if len(t) < 40 else t[:20] + "…"
        raise FormatError(f"{what} must be a whole number from 0 to {maximum}; found {shown!r}",
                          path=path, line=line)
    return int(t)


def check_file(path, *, expected: str) -> Path:
    """``path`` as a :class:`~pathlib.Path` to a file with something in it, else a
    :class:`FormatError` naming it: not found, a folder (``expected`` says what should have been
    there, e.g. ``"a motion file"``) or empty."""
    p = Path(path)
    if not p.exists():
        raise FormatError("file not found", path=p)
    if p.is_dir():
        raise FormatError(f"is a directory, expected {expected}", path=p)
    if p.stat().st_size == 0:
        raise FormatError("file is empty (0 bytes)", path=p)
    return p


def check_size(path, *, limit: int = MAX_TEXT_BYTES, what: str = "file") -> int:
    """The file's size in bytes; :class:`FormatError` when it is above ``limit``."""
    p = Path(path)
    try:
        size = p.stat().st_size
    except OSError as exc:
        raise FormatError(f"cannot read {what}: {exc.strerror}", path=p) from None
    if size > limit:
        raise FormatError(f"{what} is {size / 2**30:.1f} GiB; the reader accepts at most "
                          f"{limit / 2**30:.1f} GiB", path=p)
    return size


def read_text(path, *, what: str, encoding: str = "utf-8", errors: str = "strict") -> str:
    """A text file's content (size-checked); FormatError when unreadable or not text."""
    p = Path(path)
    check_size(p, what=what)
    try:
        return p.read_text(encoding=encoding, errors=errors)
    except UnicodeDecodeError as exc:
        raise FormatError(f"not a text {what} (byte {exc.start} is not {encoding})", path=p) from None
    except OSError as exc:
        raise FormatError(f"cannot read {what}: {exc.strerror}", path=p) from None


def csv_rows(lines, *, path, first_line: int = 1, **kwargs) -> Iterator[tuple[int, list[str]]]:
    """``(line_number, row)`` for each row of ``lines`` (an iterable of text lines or a file);
    ``csv.Error`` (a field longer than 131 072 characters, a NUL byte, ...) becomes a
    :class:`FormatError` naming the line."""
    reader = csv.reader(lines, **kwargs)
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            raise FormatError(f"not a valid CSV row ({exc})", path=path,
                              line=first_line + reader.line_num - 1) from None
        yield first_line + reader.line_num - 1, row


_JSON_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.S)


def json_depth(data: bytes) -> int:
    """The deepest nesting of ``[``/``{`` in JSON text (brackets inside strings ignored)."""
    stripped = _JSON_STRING.sub(b'""', data)
    b = np.frombuffer(stripped, dtype=np.uint8)
    step = (b == ord("[")).astype(np.int32) + (b == ord("{")) - (b == ord("]")) - (b == ord("}"))
    return int(np.cumsum(step).max(initial=0))


def _parse_int(s: str) -> int:
    if len(s.lstrip("-")) > MAX_INT_DIGITS:
        raise ValueError(f"an integer with {len(s)} digits (at most {MAX_INT_DIGITS} accepted)")
    return int(s)


def load_json(text: str | bytes, *, path=None, what: str = "JSON", max_depth: int = MAX_JSON_DEPTH) -> Any:
    """``json.loads`` with the nesting depth and integer length bounded (see the module doc)."""
    data = text.encode("utf-8", "surrogatepass") if isinstance(text, str) else bytes(text)
    depth = json_depth(data)
    if depth > max_depth:
        raise FormatError(f"{what} is nested {depth} levels deep; at most {max_depth} accepted", path=path)
    try:
        return json.loads(data, parse_int=_parse_int)
    except json.JSONDecodeError as exc:
        raise FormatError(f"{what} is not valid JSON: {exc.msg} (column {exc.colno})", path=path,
                          line=exc.lineno) from None
    except (ValueError, RecursionError, UnicodeDecodeError) as exc:
        raise FormatError(f"{what} is not valid JSON: {exc}", path=path) from None


class _Bounded(io.RawIOBase):
    """A read-only stream that refuses to deliver more than ``limit`` bytes."""

    def __init__(self, raw, limit: int, name: str):
        self.raw, self.left, self.name = raw, limit, name

    def readable(self) -> bool:
        return True

    def readinto(self, b) -> int:
        if self.left <= 0:
            if self.raw.read(1):
                raise zipfile.BadZipFile(f"member {self.name!r} holds more data than its declared size")
            return 0
        n = min(len(b), self.left)
        chunk = self.raw.read(n)
        b[:len(chunk)] = chunk
        self.left -= len(chunk)
        return len(chunk)


def load_npz_arrays(source, *, path, max_bytes: int = MAX_NPZ_BYTES, error=FormatError) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` (a path or a file object), never unpickling, with sizes checked
    before anything is decompressed or allocated.  Raises ``error`` (a HeadMotionError class)."""
    def fail(msg: str):
        if issubclass(error, FormatError):
            raise error(msg, path=path)
        raise error(f"{path}: {msg}")

    try:
        zf = zipfile.ZipFile(source)
    except (zipfile.BadZipFile, OSError, EOFError, ValueError) as exc:
        fail(f"not a readable .npz (zip) archive ({exc})")
    out: dict[str, np.ndarray] = {}
    with zf:
        infos = zf.infolist()
        if len(infos) > MAX_NPZ_MEMBERS:
            fail(f"the archive has {len(infos)} members; at most {MAX_NPZ_MEMBERS} accepted")
        total = sum(i.file_size for i in infos)
        if total > max_bytes:
            fail(f"the archive declares {total} bytes uncompressed; at most {max_bytes} accepted")
        for info in infos:
            name = info.filename
            key = name[:-4] if name.endswith(".npy") else name
            try:
                with zf.open(info) as raw:
                    fh = io.BufferedReader(_Bounded(raw, info.file_size, name))
                    version = np.lib.format.read_magic(fh)
                    if version not in ((1, 0), (2, 0), (3, 0)):
                        fail(f"member {name!r}: unknown .npy version {version}")
                    reader = {(1, 0): np.lib.format.read_array_header_1_0,
                              (2, 0): np.lib.format.read_array_header_2_0}.get(version)
                    if reader is None:
                        shape, fortran, dtype = np.lib.format._read_array_header(fh, version)
                    else:
                        shape, fortran, dtype = reader(fh)
                    if dtype.hasobject:
                        fail(f"member {name!r} holds Python objects (pickled data is never loaded)")
                    count = math.prod(shape)
                    need = count * dtype.itemsize
                    if need > info.file_size:
                        fail(f"member {name!r} declares shape {shape} ({need} bytes) but holds "
                             f"{info.file_size} bytes")
                    data = fh.read(need)
                    if len(data) != need:
                        fail(f"member {name!r} is truncated ({len(data)} of {need} bytes)")
                    arr = np.frombuffer(data, dtype=dtype, count=count)
                    arr = arr.reshape(shape[::-1]).T if fortran else arr.reshape(shape)
                    out[key] = arr.copy() if not arr.flags.writeable else arr
            except HeadMotionError:
                raise
            except (zipfile.BadZipFile, OSError, EOFError, ValueError, SyntaxError, TypeError,
                    OverflowError, MemoryError, NotImplementedError, zlib_error()) as exc:
                fail(f"member {name!r} is damaged ({type(exc).__name__}: {str(exc)[:120]})")
    return out


def zlib_error():
    import zlib

    return zlib.error


__all__ = ["FPS_RANGE", "SAMPLE_RATE_RANGE", "check_fps", "parse_count", "check_file", "check_size", "read_text",
           "csv_rows", "json_depth", "load_json", "load_npz_arrays"]
