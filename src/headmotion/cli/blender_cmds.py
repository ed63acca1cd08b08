"""``headmotion blender-addon -o headmotion_blender.zip``: the Blender add-on (:mod:`headmotion.blender`)."""

from __future__ import annotations

from pathlib import Path

import typer

from .app import app, console


@app.command("blender-addon")
def blender_addon(
    output: Path = typer.Option(Path("headmotion_blender.zip"), "-o", "--output", help="The zip to write."),
):
    """Write the Blender add-on: head motion from speech keyed on a rig's neck and head.

    Blender 3.4–4.1: Preferences → Add-ons → Install… and pick the zip; 4.2 and later: Preferences →
    Get Extensions → Install from Disk….  The add-on runs this installation's `headmotion` (on PATH,
    or the path set in its preferences)."""
    from ..blender import addon_files, write_addon

    path = write_addon(output)
    console.print(f"Blender add-on ({len(addon_files())} files) → {path}", highlight=False, soft_wrap=True)
