"""``headmotion info FILE``, ``headmotion models`` and ``headmotion convert IN OUT``.

``info`` describes a motion file (format, frames, rate, duration, joints / markers, head-rotation
SD per axis) or an audio/video file (decoder, rate, channels, duration) via
:func:`headmotion.io.motion.motion_info` and :func:`headmotion.io.audio.audio_info`.
``models`` lists the shipped models by name (:mod:`headmotion.shipped`).
``convert`` reads any motion format and writes BVH, CSV, JSON, NPZ or Live Link Face CSV.
Built on typer + rich like the rest of the CLI (click alone was considered; typer is the
project's choice); reader warnings (long gaps, marker fallbacks) are printed as one line each.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import List, Optional

import typer

from ..errors import FormatError, ParameterError
from .app import app, console, escape, print_warning
from .key_values import key_values

AUDIO_EXT = {".wav", ".flac", ".ogg", ".mp3", ".mp4", ".mkv", ".mpg", ".m4a", ".aac", ".opus", ".webm", ".aiff", ".aif"}


def _audio_info(path: Path) -> dict:
    try:
        from ..io.audio import audio_info
    except ImportError:
        try:
            import soundfile as sf
        except ImportError:
            raise ParameterError(f"{path}: audio support is not available in this installation") from None
        i = sf.info(str(path))
        return {"path": str(path), "decoder": "soundfile", "sample_rate": i.samplerate,
                "channels": i.channels, "duration": i.duration, "format": f"{i.format} {i.subtype}"}
    return audio_info(path)


def _num(v, fmt: str, unit: str = "") -> str:
    """``v`` formatted, or ``unknown`` when a file leaves it out (never a TypeError)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return "unknown" if v is None else escape(str(v))
    try:
        return format(v, fmt) + unit
    except (TypeError, ValueError):
        return escape(str(v))


def _fmt_list(xs, limit=12) -> str:
    xs = list(xs)
    s = ", ".join(map(str, xs[:limit]))
    return s + (f", … ({len(xs)} in all)" if len(xs) > limit else "")


def _model_info(file: Path, as_json: bool) -> None:
    """A model file: system, version, features, training corpus (read without unpickling)."""
    from ..models.serialization import load_model_file

    config, arrays = load_model_file(file)
    d = {"kind": "model", "system": config.get("system"), "headmotion_version": config.get("headmotion_version"),
         "corpus": config.get("corpus"), "adapted_from": config.get("adapted_from"), "arrays": len(arrays),
         "parameters": sum(int(a.size) for a in arrays.values())}
    for key in ("features", "feature_config", "feature"):
        if key in config:
            d["features"] = config[key]
            break
    if as_json:
        console.print_json(json.dumps(d, default=str))
        return
    e = lambda v: escape(str(v))  # noqa: E731 - file content is printed literally
    console.print(f"[bold]{e(file)}[/]  (model, {e(d['system'])})", highlight=False)
    console.print(f"  saved by   headmotion {e(d['headmotion_version'] or 'unknown')}", highlight=False)
    if "features" in d:
        console.print(f"  features   {e(d['features'])}", highlight=False)
    console.print(f"  arrays     {d['arrays']} ({d['parameters']:,} numbers)", highlight=False)
    c = d.get("corpus") if isinstance(d.get("corpus"), dict) else {}
    if c:
        spk = c.get("speakers") if isinstance(c.get("speakers"), list) else []
        console.print(f"  trained on {e(c.get('recordings', '?'))} recordings, {e(c.get('minutes', '?'))} min, "
                      f"{len(spk)} speaker(s), fps {e(c.get('fps', '?'))}", highlight=False)
    a = d.get("adapted_from") if isinstance(d.get("adapted_from"), dict) else {}
    if a:
        console.print(f"  adapted    from {e(a.get('base', '?'))}: {e(a.get('speech_seconds', '?'))} s of the speaker's "
                      f"speech preferred (base cost {e(a.get('base_cost', '?'))})", highlight=False)


def model_card_path(model_file: Path) -> Path:
    """The model card beside a model file: the same name with ``.md``."""
    from ..shipped import card_path

    return card_path(model_file)


def _model_card(model: str, as_json: bool) -> None:
    """``info --model NAME|PATH``: the model card (``<model>.md`` beside the file), then the file's
    summary."""
    from ..shipped import resolve_model_path

    path = resolve_model_path(model)
    if not path.is_file():
        from ..errors import ModelFileError

        raise ModelFileError(f"{path}: is not a file; expected a shipped model name or a .hmz file")
    card = model_card_path(path)
    if as_json:
        _model_info(path, True)
        return
    if card.is_file():
        console.print(card.read_text(encoding="utf-8"), markup=False, highlight=False, soft_wrap=True)
    else:
        console.print(f"(no model card: {card} does not exist)", highlight=False)
    _model_info(path, False)


@app.command("models")
def models(as_json: bool = typer.Option(False, "--json", help="print the list as JSON")):
    """The models shipped with headmotion, by name (for -m / --model), with one line of their cards."""
    from ..shipped import list_models

    shipped = list_models()
    if as_json:
        console.print_json(json.dumps([{"name": m.name, "path": str(m.path), "summary": m.summary}
                                       for m in shipped]))
        return
    if not shipped:
        console.print("no shipped model in this installation", highlight=False)
    for m in shipped:
        console.print(f"{m.name:<8} {escape(m.summary)}", highlight=False)
    if shipped:
        console.print("`headmotion info --model NAME` prints a model's card", highlight=False)


@app.command("info")
def info(
    ctx: typer.Context,
    file: Optional[Path] = typer.Argument(None, help="a motion file (bvh, csv, json, npz, c3d, glb, gltf) or an "
                                          "audio/video file"),
    as_json: bool = typer.Option(False, "--json", help="print the information as JSON"),
    model: Optional[str] = typer.Option(None, "--model",
                                        help="print a model's card: a shipped name ('default', 'stream'; `headmotion models`) or a .hmz file"),
):
    """What a motion, audio or model file holds: format, duration, rate, joints/markers, frames;
    ``--model default`` prints the bundled default model's card."""
    if model is not None:
        _model_card(model, as_json)
        return
    if file is None:  # click's usage message, as for any missing argument
        ctx.fail("Missing argument 'FILE' (or give --model default|stream|MODEL.hmz).")
    if file.suffix.lower() == ".hmz":
        _model_info(file, as_json)
        return
    if file.suffix.lower() in AUDIO_EXT:
        d = _audio_info(file)
        d = {"kind": "audio", **d}
    else:
        from ..io.motion import motion_info

        d = {"kind": "motion", **motion_info(file)}
        if d.get("n_frames") is None and str(d.get("head_motion", "")).startswith("unavailable: "):
            # nothing but the reader's complaint is known about this file: that is the error
            raise FormatError(str(d["head_motion"])[len("unavailable: "):])
    if as_json:
        console.print_json(json.dumps(d, default=str))
        return
    e = lambda v: escape(str(v))  # noqa: E731 - file content is printed literally
    console.print(f"[bold]{e(file)}[/]  ({d['kind']}, {e(d.get('format') or '?')})", highlight=False)
    if d["kind"] == "audio":
        console.print(f"  duration   {_num(d.get('duration'), '.3f', ' s')}", highlight=False)
        console.print(f"  rate       {_num(d.get('sample_rate'), 'g', ' Hz')}, {_num(d.get('channels'), 'd')} "
                      f"channel(s), decoder {e(d.get('decoder'))}", highlight=False)
        return
    console.print(f"  frames     {_num(d.get('n_frames'), 'd')}", highlight=False)
    console.print(f"  rate       {_num(d.get('fps'), 'g', ' frames/s')}", highlight=False)
    console.print(f"  duration   {_num(d.get('duration'), '.3f', ' s')}", highlight=False)
    if d.get("joints"):
        console.print(f"  joints     {len(d['joints'])}: {e(_fmt_list(d['joints']))}", highlight=False)
    if d.get("rigid_bodies"):
        console.print(f"  rigid bodies {e(_fmt_list(d['rigid_bodies']))}", highlight=False)
    if d.get("markers"):
        console.print(f"  markers    {len(d['markers'])}: {e(_fmt_list(d['markers']))}", highlight=False)
    for key, label in (("head_joint", "head joint"), ("head", "head body"), ("relative_to", "relative to"),
                       ("fallback", "note"), ("layout", "layout"), ("head_motion", "head motion")):
        if d.get(key):
            console.print(f"  {label:<10} {e(d[key])}", highlight=False, soft_wrap=True)
    s = d.get("sd_deg")
    if isinstance(s, dict):
        console.print(f"  SD (deg)   pitch {_num(s.get('pitch'), '.2f')}  yaw {_num(s.get('yaw'), '.2f')}  "
                      f"roll {_num(s.get('roll'), '.2f')}", highlight=False)
    g = d.get("gaps")
    if isinstance(g, dict):
        console.print(f"  gaps       {_num(g.get('filled_frames'), 'd')} frames filled, "
                      f"{_num(g.get('long_gaps'), 'd')} long gap(s)", highlight=False)


def _option_value(v: str):
    """A ``--option`` value: a comma-separated list, else a number, else the text."""
    if "," in v:
        return [x.strip() for x in v.split(",") if x.strip()]
    try:
        return float(v) if any(c in v for c in ".e") else int(v)
    except ValueError:
        return v


@app.command("convert")
def convert(
    src: Path = typer.Argument(..., help="input motion file (bvh, csv, json, npz, c3d, Motive/OpenFace/Live Link csv)"),
    dst: Path = typer.Argument(..., help="output file (.bvh, .csv, .json, .npz, .glb, .gltf)"),
    fmt: Optional[str] = typer.Option(None, "--format", "-f",
                                      help="output format: bvh, csv, json, npz, livelink, gltf (default: from the extension)"),
    in_format: Optional[str] = typer.Option(None, "--in-format", help="input format (default: detected)"),
    degrees: bool = typer.Option(False, "--degrees", help="CSV/JSON: write degrees instead of radians"),
    euler_order: Optional[str] = typer.Option(
        None, "--euler-order",
        help="CSV/JSON: write Euler angles in this order (e.g. YXZ) instead of rotation vectors; "
             "BVH: channel order ZXY (default) or YXZ"),
    fps: Optional[float] = typer.Option(None, "--fps", help="resample to this frame rate"),
    option: Optional[List[str]] = typer.Option(None, "--option",
                                               help="reader option KEY=VALUE (e.g. head=Head, head_markers=A,B,C)"),
):
    """Convert head motion between formats (BVH, CSV, JSON, NPZ, Live Link Face CSV; glTF out)."""
    import warnings

    from ..io.motion import load_motion, save_motion

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        motion = load_motion(src, format=in_format, **key_values(option, "--option", _option_value))
    for w in caught:
        print_warning(w.message)
    if fps is not None:
        motion = motion.resample(fps)
    out_fmt = (fmt or dst.suffix.lstrip(".")).lower()
    opts: dict = {}
    if out_fmt == "bvh":
        if degrees:
            raise ParameterError("--degrees does not apply to BVH (BVH angles are always degrees)")
        if euler_order:
            opts["channel_order"] = euler_order
    elif out_fmt in ("csv", "json"):
        opts = {"degrees": degrees, "euler_order": euler_order}
    elif degrees or euler_order:
        raise ParameterError(f"--degrees/--euler-order do not apply to the {out_fmt} format")
    save_motion(motion, dst, format=fmt, **opts)
    console.print(f"wrote {escape(str(dst))}: {len(motion)} frames at {motion.fps:g} fps ({motion.duration:.2f} s)",
                  highlight=False)
