"""Write files atomically: to a temporary file beside the target, then rename.

Used by every writer so that a failure half-way (bad input, a full disk, Ctrl-C) never leaves a
half-written output file behind, and an existing file is replaced only by a complete one.
"""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from pathlib import Path


def _umask() -> int:
    try:  # Linux: read it without changing it (os.umask is process-wide)
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path, *, suffix: str | None = None):
    """Yield a temporary path in the target's directory; rename it onto ``path`` on success.

    The temporary file keeps the target's suffix (or ``suffix``) so that libraries choosing a
    format by extension (soundfile, ffmpeg) still work.  On any exception it is deleted and the
    target is left untouched.
    """
    target = Path(path)
    sfx = target.suffix if suffix is None else suffix
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=f".part{sfx}", dir=target.parent)
    except FileExistsError:  # a file where the folder should be
        raise NotADirectoryError(errno.ENOTDIR, "a file stands where its folder should be", str(target)) from None
    except OSError as exc:
        raise _naming(exc, target) from None
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp creates 0600 files; give the output the usual permissions (0666 & ~umask)
        with contextlib.suppress(OSError):
            os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, target)
    except BaseException as exc:
        with contextlib.suppress(FileNotFoundError):
            tmp_path.unlink()
        if isinstance(exc, OSError) and str(tmp_path) in (str(exc.filename), str(exc.filename2)):
            raise _naming(exc, target) from None  # the path asked for, not the temporary file
        raise


def _naming(exc: OSError, target: Path) -> OSError:
    """``exc`` (same class, errno and reason) naming ``target``."""
    return type(exc)(exc.errno, exc.strerror or str(exc), str(target))


@contextlib.contextmanager
def atomic_open(path, mode: str = "w", **kwargs):
    """``open()`` a temporary file and rename it onto ``path`` when the block succeeds."""
    with atomic_path(path) as tmp:
        with open(tmp, mode, **kwargs) as fh:
            yield fh


def atomic_write_text(path, text: str, encoding: str = "utf-8") -> None:
    with atomic_open(path, "w", encoding=encoding, newline="") as fh:
        fh.write(text)


def atomic_write_bytes(path, data: bytes) -> None:
    with atomic_open(path, "wb") as fh:
        fh.write(data)


__all__ = ["atomic_path", "atomic_open", "atomic_write_text", "atomic_write_bytes"]
