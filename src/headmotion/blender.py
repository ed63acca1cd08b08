"""The Blender add-on ``headmotion_blender``, shipped in the package and written as a zip.

The add-on's source is package data (``headmotion/blender_addon/headmotion_blender``: it imports
Blender's ``bpy``, so it is not a module of this package).  :func:`write_addon` writes it as one
zip with the add-on's folder at its root: Blender 3.4 to 4.1 install it as a legacy add-on
(Preferences > Add-ons > Install), 4.2 and later as an extension (Install from Disk: the
``blender_manifest.toml`` in that one folder).  The zip's entries have a fixed time stamp, so the
same add-on makes the same bytes.
"""

from __future__ import annotations

import zipfile
from pathlib import Path

from .errors import ParameterError
from .io.atomic import atomic_path

ADDON_NAME = "headmotion_blender"


def addon_source() -> Path:
    """The folder of the add-on's files in this installation."""
    return Path(__file__).resolve().parent / "blender_addon" / ADDON_NAME


def addon_files() -> list[Path]:
    """The add-on's files (no caches), sorted."""
    src = addon_source()
    return sorted(p for p in src.rglob("*") if p.is_file() and "__pycache__" not in p.parts
                  and p.suffix not in (".pyc", ".pyo"))


def write_addon(path) -> Path:
    """Write the add-on as a zip at ``path`` (atomically); returns the path.

    Raises :class:`~headmotion.errors.ParameterError` when ``path`` does not end in ``.zip``."""
    path = Path(path)
    if path.suffix.lower() != ".zip":
        raise ParameterError(f"the Blender add-on is written as a .zip file; got {path}")
    src = addon_source()
    with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for f in addon_files():
            info = zipfile.ZipInfo(f"{ADDON_NAME}/{f.relative_to(src).as_posix()}", date_time=(2020, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, f.read_bytes())
    return path


__all__ = ["ADDON_NAME", "addon_files", "addon_source", "write_addon"]
