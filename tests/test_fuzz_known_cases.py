"""Damaged files of every format, one by one: each reader checks before it trusts.

Declared counts and sizes against the file, rates within 1–1000 fps (1 kHz–384 kHz audio), JSON
depth and integer length, CSV field size, npz/zip member sizes before decompressing, the model
config's schema.  Every failure is a HeadMotionError naming the file (and the line where there is
one)."""

from __future__ import annotations

import io
import json
import struct
import time
import zipfile

import numpy as np
import pytest

from headmotion.errors import AudioLoadingError, FormatError, HeadMotionError, ModelFileError
from headmotion.types import Motion


def _motion(T=30, fps=30.0):
    t = np.arange(T) / fps
    return Motion(np.stack([0.1 * np.sin(t), 0.2 * np.cos(t), 0.05 * t], 1), fps,
                  translation=np.zeros((T, 3)))


@pytest.fixture
def bvh_text(tmp_path):
    from headmotion.io.bvh import save_bvh

    p = tmp_path / "seed.bvh"
    save_bvh(_motion(), p)
    return p.read_text()


def _edit(tmp_path, text, a, b, name="x.bvh"):
    assert a in text
    p = tmp_path / name
    p.write_text(text.replace(a, b, 1))
    return p


# ----------------------------------------------------------------------------------------- BVH
def test_bvh_huge_frame_count_is_checked_against_the_file(tmp_path, bvh_text):
    from headmotion.io.bvh import load_bvh

    p = _edit(tmp_path, bvh_text, "Frames: 30", "Frames: 1000000000")
    t0 = time.perf_counter()
    with pytest.raises(FormatError, match=r"x\.bvh, line \d+: 'Frames: 1000000000' but the file holds 30"):
        load_bvh(p)
    assert time.perf_counter() - t0 < 5  # no 112 GiB allocation attempted


@pytest.mark.parametrize("bad", ["-3", "3.5", "1e9", "9" * 5000, ""])
def test_bvh_frames_must_be_a_count(tmp_path, bvh_text, bad):
    from headmotion.io.bvh import load_bvh

    with pytest.raises(FormatError, match="Frames"):
        load_bvh(_edit(tmp_path, bvh_text, "Frames: 30", f"Frames: {bad}"))


@pytest.mark.parametrize("a,b,match", [
    ("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 300 Zrotation Xrotation Yrotation", "CHANNELS count"),
    ("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 3 Zrotation Zrotation Yrotation", "twice"),
    ("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 2 Zrotation Xrotation", "frame line has 15 values, expected 14"),
    ("CHANNELS 3 Zrotation Xrotation Yrotation", "CHANNELS 3 Zrotation Xrotation Wrotation", "unknown channel"),
])
def test_bvh_channel_counts(tmp_path, bvh_text, a, b, match):
    from headmotion.io.bvh import load_bvh

    with pytest.raises(FormatError, match=match):
        load_bvh(_edit(tmp_path, bvh_text, a, b))


@pytest.mark.parametrize("ft", ["0", "1e-320", "inf", "nan", "-0.033", "2", "0.0001"])
def test_bvh_frame_time_must_be_sane(tmp_path, bvh_text, ft):
    from headmotion.io.bvh import load_bvh

    with pytest.raises(FormatError, match=r"line \d+: Frame Time .*1–1000 frames/s"):
        load_bvh(_edit(tmp_path, bvh_text, "Frame Time: 0.0333333333333", f"Frame Time: {ft}"))


@pytest.mark.parametrize("ft,fps", [("0.001", 1000.0), ("1", 1.0), ("0.01", 100.0)])
def test_bvh_frame_time_limits_are_inclusive(tmp_path, bvh_text, ft, fps):
    from headmotion.io.bvh import load_bvh

    assert load_bvh(_edit(tmp_path, bvh_text, "Frame Time: 0.0333333333333", f"Frame Time: {ft}")).fps == fps


def test_bvh_nan_sample_names_the_line(tmp_path, bvh_text):
    from headmotion.io.bvh import load_bvh

    lines = bvh_text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("Frame Time")) + 5
    vals = lines[k].split()
    vals[10] = "nan"
    lines[k] = " ".join(vals)
    p = tmp_path / "nan.bvh"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError, match=rf"nan\.bvh, line {k + 1}: .*NaN or inf"):
        load_bvh(p)


# ---------------------------------------------------------------------------------- OptiTrack
def _motive(rate_fields="Capture Frame Rate,120,Export Frame Rate,120", rows=None, markers=False):
    head = f"Format Version,1.23,{rate_fields},Rotation Type,Quaternion,Length Units,Millimeters\n\n"
    if markers:
        names = ["HeadA", "HeadB", "HeadC", "HeadD"]
        head += ",Type," + ",".join(["Marker"] * 12) + "\n"
        head += ",Name," + ",".join(n for n in names for _ in range(3)) + "\n"
        head += ",," + ",".join(["Position"] * 12) + "\nFrame,Time (Seconds)," + ",".join("XYZ" * 4) + "\n"
        base = np.array([[0, 0, 0], [100, 0, 0], [0, 100, 0], [0, 0, 100]], float)
        rows = rows or [[k, k / 120] + list((base + [k, 2 * k, 0]).ravel()) for k in range(40)]
    else:
        head += ",Type,Rigid Body,Rigid Body,Rigid Body,Rigid Body\n,Name,Head,Head,Head,Head\n"
        head += ",,Rotation,Rotation,Rotation,Rotation\nFrame,Time (Seconds),X,Y,Z,W\n"
        rows = rows or [[k, k / 120, 0, np.sin(k / 20) * 0.1, 0, np.cos(k / 20) * 0.1] for k in range(40)]
        rows = [[r[0], r[1], *(np.array(r[2:]) / np.linalg.norm(r[2:]))] for r in rows]
    return head + "\n".join(",".join("" if (isinstance(v, float) and np.isnan(v) and False) else f"{v}"
                                     for v in r) for r in rows) + "\n"


@pytest.mark.parametrize("fields", ["Capture Frame Rate,0,Export Frame Rate,0",
                                    "Capture Frame Rate,inf,Export Frame Rate,inf",
                                    "Capture Frame Rate,1e9,Export Frame Rate,1e9",
                                    "Capture Frame Rate,abc,Export Frame Rate,-1"])
def test_optitrack_rate_in_header_must_be_sane(tmp_path, fields):
    from headmotion.io.optitrack import load_optitrack

    p = tmp_path / "take.csv"
    p.write_text(_motive(fields))
    with pytest.raises(FormatError, match=r"take\.csv, line 1: 'Export Frame Rate'"):
        load_optitrack(p)


def test_optitrack_missing_rate_comes_from_the_time_column(tmp_path):
    from headmotion.io.optitrack import load_optitrack

    p = tmp_path / "take.csv"
    p.write_text(_motive("Take Name,t"))
    assert load_optitrack(p).fps == pytest.approx(120.0)


def test_optitrack_missing_rate_and_broken_time_column(tmp_path):
    from headmotion.io.optitrack import load_optitrack

    p = tmp_path / "take.csv"
    rows = [[k, 0.0, 0, 0, 0, 1] for k in range(10)]
    p.write_text(_motive("Take Name,t", rows=rows))
    with pytest.raises(FormatError, match="no frame rate"):
        load_optitrack(p)


def test_optitrack_nan_marker_columns_are_gaps(tmp_path):
    from headmotion.io.optitrack import load_optitrack

    base = np.array([[0, 0, 0], [100, 0, 0], [0, 100, 0], [0, 0, 100]], float)
    rows = []
    for k in range(40):
        pts = (base + [k, 2 * k, 0]).ravel().tolist()
        if 10 <= k < 13:
            pts = [float("nan")] * 12  # the whole marker set lost for 3 frames
        if k == 20:
            pts[0:3] = [float("inf")] * 3
        rows.append([k, k / 120] + pts)
    p = tmp_path / "markers.csv"
    p.write_text(_motive(rows=rows, markers=True).replace("nan", "NaN"))
    m = load_optitrack(p, head_markers=["HeadA", "HeadB", "HeadC", "HeadD"])
    assert np.all(np.isfinite(m.rotvec)) and m.meta["gaps"]["filled_frames"] == 3
    assert np.abs(m.rotvec).max() < 1e-6  # the set only translates


def test_optitrack_absurd_coordinate_is_an_error(tmp_path):
    from headmotion.io.optitrack import load_optitrack

    text = _motive(markers=True)
    lines = text.splitlines()
    cells = lines[8].split(",")
    cells[4] = "1e300"
    lines[8] = ",".join(cells)
    p = tmp_path / "m.csv"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError, match=r"m\.csv, line 9: .*plausible"):
        load_optitrack(p, head_markers=["HeadA", "HeadB", "HeadC", "HeadD"])


# ---------------------------------------------------------------------------- native formats
def test_json_deep_nesting_and_long_integers(tmp_path):
    from headmotion.io.native import load_json, save_json

    p = tmp_path / "m.json"
    save_json(_motion(), p)
    doc = p.read_text()
    (tmp_path / "deep.json").write_text(doc.replace('"meta":', '"x":' + "[" * 100_000 + "]" * 100_000 + ',"meta":'))
    with pytest.raises(FormatError, match=r"deep\.json: .*nested 100001 levels"):
        load_json(tmp_path / "deep.json")
    (tmp_path / "int.json").write_text(doc.replace('"fps":30.0', '"fps":' + "9" * 5000))
    with pytest.raises(FormatError, match=r"int\.json: .*5000 digits"):
        load_json(tmp_path / "int.json")
    for bad in ("0", "1e-320", "1e308", "NaN", "Infinity", "true", '"30"x'):
        (tmp_path / "fps.json").write_text(doc.replace('"fps":30.0', f'"fps":{bad}'))
        with pytest.raises(FormatError, match=r"fps\.json"):
            load_json(tmp_path / "fps.json")


def test_csv_huge_field_and_bad_rates(tmp_path):
    from headmotion.io.native import load_csv, save_csv

    p = tmp_path / "m.csv"
    save_csv(_motion(), p)
    lines = p.read_text().splitlines()
    lines[5] = lines[5] + "," + "1" * 200_000
    (tmp_path / "huge.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError, match=r"huge\.csv, line 6: not a valid CSV row \(field larger"):
        load_csv(tmp_path / "huge.csv")
    (tmp_path / "rate.csv").write_text(p.read_text().replace('"fps":30.0', '"fps":1e-320'))
    with pytest.raises(FormatError, match=r"rate\.csv, line 1: header 'fps'"):
        load_csv(tmp_path / "rate.csv")
    (tmp_path / "times.csv").write_text("frame,time,rx,ry,rz\n0,0,0,0,0\n1,0,0,0,0\n")
    with pytest.raises(FormatError, match="increasing time"):
        load_csv(tmp_path / "times.csv")


def _npz_bytes(**arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def test_npz_declared_shape_is_checked_before_allocating(tmp_path):
    from headmotion.io.native import load_npz

    raw = _npz_bytes(rotvec=np.zeros((4, 3)), fps=np.float64(30))
    # rewrite the .npy header of rotvec to claim 10^11 rows
    header_old = b"'shape': (4, 3)"
    assert header_old in raw
    buf = io.BytesIO()
    with zipfile.ZipFile(io.BytesIO(raw)) as zin, zipfile.ZipFile(buf, "w") as zout:
        for info in zin.infolist():
            data = zin.read(info)
            if info.filename == "rotvec.npy":
                data = data.replace(header_old, b"'shape': (100000000000, 3)"[:len(header_old) + 12])
                h = data[10:].split(b"}", 1)
                data = data[:10] + h[0] + b"}" + h[1]
            zout.writestr(info.filename, data)
    p = tmp_path / "liar.npz"
    p.write_bytes(buf.getvalue())
    t0 = time.perf_counter()
    with pytest.raises(FormatError, match=r"liar\.npz: .*rotvec\.npy.*declares shape"):
        load_npz(p)
    assert time.perf_counter() - t0 < 5


@pytest.mark.parametrize("arrays,match", [
    (dict(rotvec=np.zeros((4, 3)), fps=np.array([30.0, 30.0])), "'fps' must be one number"),
    (dict(rotvec=np.zeros((4, 3)), fps=np.float64(1e9)), "'fps'"),
    (dict(rotvec=np.zeros((4, 3)), fps=np.float64(np.nan)), "'fps'"),
    (dict(rotvec=np.full((4, 3), np.inf), fps=np.float64(30)), "NaN or inf"),
    (dict(rotvec=np.zeros((4, 3)), fps=np.float64(30), meta_json=np.array("[" * 10_000)), "nested"),
    (dict(rotvec=np.array(["a", "b"]), fps=np.float64(30)), "must hold numbers"),
    (dict(rotvec=np.zeros((4, 3)), fps=np.float64(30), translation=np.zeros((3, 3))), "translation"),
])
def test_npz_values(tmp_path, arrays, match):
    from headmotion.io.native import load_npz

    p = tmp_path / "m.npz"
    p.write_bytes(_npz_bytes(**arrays))
    with pytest.raises(FormatError, match=match):
        load_npz(p)


def test_livelink_nan_head_angle(tmp_path):
    from headmotion.io.livelink import load_livelink, save_livelink

    p = tmp_path / "ll.csv"
    save_livelink(_motion(), p)
    lines = p.read_text().splitlines()
    cells = lines[3].split(",")
    cells[54] = "nan"
    lines[3] = ",".join(cells)
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError, match=r"ll\.csv, line 4: head angles"):
        load_livelink(p)
    with pytest.raises(HeadMotionError, match="fps="):
        load_livelink(tmp_path / "ll.csv", fps=0)


# ----------------------------------------------------------------------------------- audio
def _wav(tmp_path):
    import soundfile as sf

    p = tmp_path / "a.wav"
    sf.write(str(p), 0.1 * np.sin(np.arange(1600) / 3), 16000, subtype="PCM_16")
    return p


@pytest.mark.parametrize("offset,size,value,match", [
    (24, 4, 0, "sample rate 0"), (24, 4, 7, "sample rate 7"), (24, 4, 10**9, "sample rate 1000000000"),
    (22, 2, 0, "0 channels"), (34, 2, 0, "0 bits"), (40, 4, 10**8, "truncated"),
])
def test_wav_damaged_header(tmp_path, offset, size, value, match):
    from headmotion.io.audio import audio_info, load_audio

    p = _wav(tmp_path)
    b = bytearray(p.read_bytes())
    b[offset:offset + size] = value.to_bytes(size, "little")
    p.write_bytes(bytes(b))
    with pytest.raises(AudioLoadingError, match=rf"a\.wav: .*{match}"):
        load_audio(p)
    with pytest.raises(AudioLoadingError, match=r"a\.wav"):
        audio_info(p)


# ----------------------------------------------------------------------------------- model
def _model(tmp_path):
    from headmotion.models.serialization import save_model_file

    p = tmp_path / "m.hmz"
    save_model_file(p, system="tws-hier", config={"params": {"k": 4}}, arrays={"w": np.arange(6.0)})
    return p


def _rezip(src, dst, *, config=None, arrays=None, compression=zipfile.ZIP_STORED):
    with zipfile.ZipFile(src) as zf:
        c = zf.read("config.json") if config is None else config
        a = zf.read("arrays.npz") if arrays is None else arrays
    with zipfile.ZipFile(dst, "w", compression=compression) as zf:
        zf.writestr("config.json", c)
        zf.writestr("arrays.npz", a)
    return dst


def test_model_zip_bomb_is_refused_before_decompressing(tmp_path):
    from headmotion.models.serialization import load_model_file

    p = _rezip(_model(tmp_path), tmp_path / "bomb.hmz", arrays=b"\0" * (200 << 20),
               compression=zipfile.ZIP_DEFLATED)
    assert p.stat().st_size < 1 << 20
    t0 = time.perf_counter()
    with pytest.raises(ModelFileError, match=r"bomb\.hmz: arrays\.npz would expand"):
        load_model_file(p)
    assert time.perf_counter() - t0 < 2


@pytest.mark.parametrize("change,match", [
    ({"system": None}, "'system'"), ({"format_version": "1"}, "'format_version'"),
    ({"params": [1, 2]}, "'params'"), ({"corpus": 5}, "'corpus'"), ({"format": "other"}, "not a headmotion"),
    ({"format_version": 10**60}, "digits|newer"),
])
def test_model_config_schema(tmp_path, change, match):
    from headmotion.models.serialization import load_model_file

    src = _model(tmp_path)
    with zipfile.ZipFile(src) as zf:
        cfg = json.loads(zf.read("config.json"))
    cfg.update(change)
    p = _rezip(src, tmp_path / "bad.hmz", config=json.dumps(cfg))
    with pytest.raises(ModelFileError, match=match):
        load_model_file(p)


def test_model_config_deep_nesting(tmp_path):
    from headmotion.models.serialization import load_model_file

    src = _model(tmp_path)
    with zipfile.ZipFile(src) as zf:
        text = zf.read("config.json").decode()
    p = _rezip(src, tmp_path / "deep.hmz", config=text.replace('"params":', '"x":' + "[" * 10**5 + "]" * 10**5 + ',"params":'))
    with pytest.raises(ModelFileError, match="nested"):
        load_model_file(p)


def test_model_array_header_lies(tmp_path):
    from headmotion.models.serialization import load_model_file

    src = _model(tmp_path)
    arrays = _npz_bytes(w=np.arange(6.0)).replace(b"'shape': (6,)", b"'shape': (9999999999,)"[:13 + 0])
    p = _rezip(src, tmp_path / "lie.hmz", arrays=arrays)
    with pytest.raises(ModelFileError, match=r"lie\.hmz"):
        load_model_file(p)


def test_default_model_still_loads():
    from importlib.resources import files

    from headmotion.models.serialization import load_model_file

    p = files("headmotion") / "data" / "default_model.hmz"
    if not p.is_file():
        pytest.skip("no default model in this checkout")
    config, arrays = load_model_file(p)
    assert config["system"] and len(arrays) >= 5


# -------------------------------------------------------------------------------------- C3D
def test_c3d_header_declaring_more_frames_than_the_file(tmp_path):
    from repo_scripts import load_script

    from headmotion.io.c3d import load_c3d

    fz = load_script("scripts/fuzz.py", "fz")
    p = fz.make_seed("c3d", tmp_path)
    assert len(load_c3d(p)) == 40
    b = bytearray(p.read_bytes())
    b[8:10] = struct.pack("<H", 60000)  # last frame
    p.write_bytes(bytes(b))
    with pytest.raises(FormatError, match=r"seed_c3d\.c3d: the header declares 60000 frames"):
        load_c3d(p)
