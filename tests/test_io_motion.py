"""Motion formats: round trips of every writer, synthetic files with known answers, bad input,
and the ``info`` / ``convert`` commands."""

from __future__ import annotations

import csv
import json
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.errors import FormatError, NoHeadError, ParameterError
from headmotion.io._mocap import MotionGapWarning
from headmotion.io.motion import load_motion, motion_info, save_motion
from headmotion.types import Motion


def _motion(n=120, fps=50.0, seed=0, translation=False):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / fps
    rv = np.stack([0.3 * np.sin(2 * np.pi * 0.7 * t + rng.uniform(0, 6)),
                   0.5 * np.sin(2 * np.pi * 0.4 * t + rng.uniform(0, 6)),
                   0.2 * np.sin(2 * np.pi * 1.1 * t + rng.uniform(0, 6))], 1)
    tr = rng.normal(scale=0.01, size=(n, 3)) if translation else None
    return Motion(rv, fps, translation=tr, meta={"speaker": "s1", "note": "synthetic"})


def _angle_err(a, b):
    return (Rotation.from_rotvec(np.array(a)).inv() * Rotation.from_rotvec(np.array(b))).magnitude().max()


# ------------------------------------------------------------------------------ round trips
@pytest.mark.parametrize("order", ["ZXY", "YXZ"])
@pytest.mark.parametrize("neck_share", [0.0, 0.5])
def test_bvh_round_trip(tmp_path, order, neck_share):
    m = _motion(fps=24.0)
    p = tmp_path / "a.bvh"
    save_motion(m, p, channel_order=order, neck_share=neck_share)
    text = p.read_text()
    assert f"CHANNELS 3 {' '.join(a + 'rotation' for a in order)}" in text
    assert "Frame Time: 0.0416666666667" in text
    r = load_motion(p)
    assert r.fps == 24.0 and len(r) == len(m)
    assert _angle_err(r.rotvec, m.rotvec) < 1e-6
    assert r.meta["head_joint"] == "Head" and r.meta["relative_to"] == "Spine"
    assert r.meta["chain"] == ["Neck", "Head"]


def test_bvh_writer_head_channels_are_scipy_euler(tmp_path):
    """Independent reader: the Head joint's channels are intrinsic Euler angles in the channel order."""
    m = _motion(n=10)
    p = tmp_path / "a.bvh"
    save_motion(m, p, neck_share=0.0)
    lines = p.read_text().splitlines()
    k = lines.index("MOTION")
    frame = np.array(lines[k + 3 + 4].split(), float)
    assert len(frame) == 15
    np.testing.assert_allclose(frame[9:12], 0.0)  # neck at zero
    R = Rotation.from_euler("ZXY", frame[12:15], degrees=True)
    assert (R.inv() * Rotation.from_rotvec(np.array(m.rotvec[4]))).magnitude() < 1e-7


@pytest.mark.parametrize("ext", ["csv", "json", "npz"])
def test_native_round_trip(tmp_path, ext):
    m = _motion(translation=True)
    p = tmp_path / f"a.{ext}"
    save_motion(m, p)
    r = load_motion(p)
    assert r.fps == m.fps
    np.testing.assert_allclose(r.rotvec, m.rotvec, atol=1e-9)
    np.testing.assert_allclose(r.translation, m.translation, atol=1e-9)
    assert r.meta["speaker"] == "s1"


@pytest.mark.parametrize("ext", ["csv", "json"])
@pytest.mark.parametrize("degrees", [False, True])
@pytest.mark.parametrize("order", [None, "YXZ", "zyx"])
def test_native_euler_and_degree_exports(tmp_path, ext, degrees, order):
    m = _motion()
    p = tmp_path / f"a.{ext}"
    save_motion(m, p, degrees=degrees, euler_order=order)
    r = load_motion(p)
    assert _angle_err(r.rotvec, m.rotvec) < 1e-8
    if ext == "csv" and order == "YXZ" and degrees:
        header = p.read_text().splitlines()[1].split(",")
        assert header == ["frame", "time", "yaw_deg", "pitch_deg", "roll_deg"]
        row = np.array(p.read_text().splitlines()[2 + 7].split(","), float)
        np.testing.assert_allclose(row[[3, 2, 4]], m.as_pitch_yaw_roll(degrees=True)[7], atol=1e-9)


def test_plain_csv_without_header_line(tmp_path):
    p = tmp_path / "plain.csv"
    p.write_text("time,pitch_deg,yaw_deg,roll_deg\n0,10,0,0\n0.01,0,20,0\n0.02,0,0,-5\n")
    r = load_motion(p, euler_order="XYZ")
    assert r.fps == pytest.approx(100.0)
    np.testing.assert_allclose(np.degrees(r.rotvec), [[10, 0, 0], [0, 20, 0], [0, 0, -5]], atol=1e-9)


def test_livelink_round_trip_and_columns(tmp_path):
    from headmotion.io.livelink import COLUMNS

    m = _motion(n=130, fps=60.0)
    p = tmp_path / "take.csv"
    save_motion(m, p, format="livelink")
    rows = list(csv.reader(p.open()))
    assert tuple(rows[0]) == COLUMNS and len(rows[0]) == 63
    assert rows[1][0] == "00:00:00:00.000" and rows[61][0] == "00:00:01:00.000" and rows[1][1] == "61"
    assert all(len(r) == 63 for r in rows)
    r = load_motion(p)  # sniffed as Live Link
    assert r.meta["format"] == "livelink" and r.fps == 60.0
    assert _angle_err(r.rotvec, m.rotvec) < 1e-8
    # the head columns are yaw/pitch/roll (YXZ) in radians
    yaw, pitch, roll = (float(rows[5][COLUMNS.index(c)]) for c in ("HeadYaw", "HeadPitch", "HeadRoll"))
    np.testing.assert_allclose([pitch, yaw, roll], m.as_pitch_yaw_roll()[4], atol=1e-9)


def test_livelink_matches_real_header(shared_data):
    from headmotion.io.livelink import COLUMNS

    f = shared_data / "formats/livelink/JMTechArt_MySlate_3_iPhone.csv"
    if not f.exists():
        pytest.skip("Live Link sample absent")
    assert tuple(next(csv.reader(f.open()))) == COLUMNS


# ------------------------------------------------------------------------ synthetic BVH reading
def _bvh_text(channel_orders, frames, names=("Hips", "Chest", "Neck", "Head")):
    out = ["HIERARCHY"]
    for k, (n, o) in enumerate(zip(names, channel_orders)):
        out.append(("ROOT " if k == 0 else "JOINT ") + n)
        out.append("{")
        out.append("OFFSET 0 10 0")
        chans = ([f"{a}position" for a in "XYZ"] if k == 0 else []) + [f"{a}rotation" for a in o]
        out.append(f"CHANNELS {len(chans)} {' '.join(chans)}")
    out += ["End Site", "{", "OFFSET 0 5 0", "}"] + ["}"] * len(names)
    out += ["MOTION", f"Frames: {len(frames)}", "Frame Time: 0.01"]
    out += [" ".join(f"{v:.8f}" for v in f) for f in frames]
    return "\n".join(out) + "\n"


def test_bvh_any_channel_order_composes_neck_chain(tmp_path):
    rng = np.random.default_rng(3)
    orders = ["ZYX", "XZY", "YXZ", "ZXY"]
    T = 6
    angles = rng.uniform(-40, 40, size=(T, 4, 3))
    frames = [np.concatenate([[1, 2, 3]] + [angles[t, j] for j in range(4)]) for t in range(T)]
    p = tmp_path / "s.bvh"
    p.write_text(_bvh_text(orders, frames))
    m = load_motion(p)
    assert m.meta["relative_to"] == "Chest" and m.meta["chain"] == ["Neck", "Head"]
    for t in range(T):
        expect = Rotation.from_euler("YXZ", angles[t, 2], degrees=True) * Rotation.from_euler(
            "ZXY", angles[t, 3], degrees=True)
        assert (expect.inv() * Rotation.from_rotvec(np.array(m.rotvec[t]))).magnitude() < 1e-7
    w = load_motion(p, relative_to="world")
    g = Rotation.identity()
    for j, o in enumerate(orders):
        g = g * Rotation.from_euler(o, angles[0, j], degrees=True)
    assert (g.inv() * Rotation.from_rotvec(np.array(w.rotvec[0]))).magnitude() < 1e-7


def test_bvh_head_found_by_name_variants(tmp_path):
    p = tmp_path / "mixamo.bvh"
    p.write_text(_bvh_text(["ZXY"] * 4, [np.zeros(15)],
                           names=("mixamorig:Hips", "mixamorig:Spine2", "mixamorig:Neck", "mixamorig:Head")))
    m = load_motion(p)
    assert m.meta["head_joint"] == "mixamorig:Head" and m.meta["relative_to"] == "mixamorig:Spine2"
    m = load_motion(p, head="mixamorig:Neck")
    assert m.meta["chain"] == ["mixamorig:Neck"]


# ------------------------------------------------------------------------------ bad input
def test_bvh_without_head(tmp_path):
    p = tmp_path / "nohead.bvh"
    p.write_text(_bvh_text(["ZXY"] * 3, [np.zeros(12)], names=("Hips", "Spine", "LeftArm")))
    with pytest.raises(NoHeadError, match=r"nohead\.bvh.*Hips, Spine, LeftArm"):
        load_motion(p)
    with pytest.raises(NoHeadError, match="no joint named 'Skull'"):
        load_motion(p, head="Skull")


def test_bvh_frame_line_wrong_count(tmp_path):
    frames = [np.zeros(15), np.zeros(14), np.zeros(15)]
    p = tmp_path / "bad.bvh"
    p.write_text(_bvh_text(["ZXY"] * 4, frames))
    n_line = p.read_text().splitlines().index("MOTION") + 5  # 1-based line of the 2nd frame
    with pytest.raises(FormatError, match=rf"bad\.bvh, line {n_line}: frame line has 14 values, expected 15") as e:
        load_motion(p)
    assert e.value.line == n_line


def test_bvh_truncated(tmp_path):
    p = tmp_path / "trunc.bvh"
    text = _bvh_text(["ZXY"] * 4, [np.zeros(15)] * 3).replace("Frames: 3", "Frames: 5")
    p.write_text(text)
    with pytest.raises(FormatError, match="Frames: 5.*3 frame lines"):
        load_motion(p)


def _motive_csv(path, *, markers: dict | None = None, rigid: dict | None = None, fps=100.0):
    """Write a Motive 1.2x-style CSV: markers {name: (T,3) mm}, rigid {name: ((T,4) xyzw, (T,3))}."""
    markers = markers or {}
    rigid = rigid or {}
    T = len(next(iter({**markers, **rigid}.values()))[0]) if rigid else (
        len(next(iter(markers.values()))) if markers else 3)
    types, names, ids, kinds, axes, cols = [], [], [], [], [], []
    for n, (q, pos) in rigid.items():
        for a, v in zip("XYZW", q.T):
            types.append("Rigid Body"); names.append(n); ids.append("1"); kinds.append("Rotation"); axes.append(a); cols.append(v)
        for a, v in zip("XYZ", pos.T):
            types.append("Rigid Body"); names.append(n); ids.append("1"); kinds.append("Position"); axes.append(a); cols.append(v)
    for n, p in markers.items():
        for a, v in zip("XYZ", p.T):
            types.append("Marker"); names.append(n); ids.append("2"); kinds.append("Position"); axes.append(a); cols.append(v)
    lines = [f"Format Version,1.23,Take Name,synthetic,Capture Frame Rate,{fps:.6f},Export Frame Rate,{fps:.6f},"
             "Rotation Type,Quaternion,Length Units,Millimeters,Coordinate Space,Global", "",
             ",Type," + ",".join(types), ",Name," + ",".join(names), ",ID," + ",".join(ids),
             ",," + ",".join(kinds), "Frame,Time (Seconds)," + ",".join(axes)]
    for t in range(T):
        vals = ["" if not np.isfinite(c[t]) else f"{c[t]:.9f}" for c in cols]
        lines.append(f"{t},{t / fps:.6f}," + ",".join(vals))
    path.write_text("\n".join(lines) + "\n")


def _track(T, fps, amp, freq, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(T) / fps
    ph = rng.uniform(0, 6, 3)
    return Rotation.from_rotvec(np.stack([amp[k] * np.sin(2 * np.pi * freq[k] * t + ph[k]) for k in range(3)], 1))


def test_motive_markers_head_relative_to_body(tmp_path):
    T, fps = 200, 100.0
    rng = np.random.default_rng(1)
    head_shape = rng.normal(scale=60, size=(4, 3))
    body_shape = rng.normal(scale=150, size=(5, 3))
    Rb = _track(T, fps, (0.05, 0.1, 0.03), (0.2, 0.3, 0.25), 2)
    Rh = Rb * _track(T, fps, (0.3, 0.5, 0.2), (0.9, 0.6, 1.3), 3)
    ph = np.stack([Rh[t].apply(head_shape) for t in range(T)]) + [0, 1500, 0]
    pb = np.stack([Rb[t].apply(body_shape) for t in range(T)]) + [0, 1100, 0]
    ph[50:55, 0] = np.nan  # a 5-frame gap of one head marker (3 remain)
    ph[100:106, :, :] = np.nan  # 6 frames without any head marker → interpolated (0.06 s ≤ 0.1 s)
    ph[150:170, :, :] = np.nan  # 0.2 s gap → filled but reported
    mk = {f"Head:M{k}": ph[:, k] for k in range(4)} | {f"Body:M{k}": pb[:, k] for k in range(5)}
    p = tmp_path / "take.csv"
    _motive_csv(p, markers=mk, fps=fps)
    with pytest.warns(MotionGapWarning, match="longer than 0.1 s"):
        m = load_motion(p)
    assert m.meta["format"] == "optitrack" and len(m) == T and m.fps == fps
    assert m.meta["head_markers"] == [f"Head:M{k}" for k in range(4)]
    assert m.meta["gaps"]["long_gaps"] == [[1.5, 1.7]]
    # expected: each set relative to its mean orientation, head relative to body
    good = np.ones(T, bool)
    good[100:106] = good[150:170] = False
    sh = Rh * Rh[good].mean().inv()  # the mean over the frames where the head was seen
    sb = Rb * Rb.mean().inv()
    expect = (sb.inv() * sh).as_rotvec()
    assert _angle_err(m.rotvec[good], expect[good]) < 1e-6
    assert _angle_err(m.rotvec[100:106], expect[100:106]) < 0.02  # interpolated
    np.testing.assert_allclose(m.translation.mean(0), 0, atol=1e-12)  # mean position reset


def test_motive_rigid_bodies(tmp_path):
    T, fps = 50, 120.0
    Rb = _track(T, fps, (0.05, 0.2, 0.03), (0.2, 0.3, 0.25), 4)
    Rh = _track(T, fps, (0.3, 0.5, 0.2), (0.9, 0.6, 1.3), 5)
    q_h = Rh.as_quat()
    q_h[10] = np.nan
    p = tmp_path / "rb.csv"
    _motive_csv(p, rigid={"Head": (q_h, np.zeros((T, 3)) + [0, 1500, 0]),
                          "Torso": (Rb.as_quat(), np.zeros((T, 3)) + [0, 1100, 0])}, fps=fps)
    m = load_motion(p)
    assert m.meta["head"] == "Head" and m.meta["relative_to"] == "Torso" and m.fps == 120.0
    expect = (Rb.inv() * Rh).as_rotvec()
    keep = np.arange(T) != 10
    assert _angle_err(m.rotvec[keep], expect[keep]) < 1e-7
    assert m.meta["gaps"]["filled_frames"] == 1


def test_motive_csv_with_no_objects(tmp_path):
    p = tmp_path / "empty_take.csv"
    p.write_text("Format Version,1.23,Take Name,x,Export Frame Rate,100\n\n,Type\n,Name\n,ID\n,\nFrame,Time (Seconds)\n"
                 "0,0.0\n1,0.01\n")
    with pytest.raises(FormatError, match=r"empty_take\.csv.*no objects"):
        load_motion(p)


def test_motive_missing_named_markers(tmp_path):
    p = tmp_path / "m.csv"
    pts = np.zeros((5, 3))
    _motive_csv(p, markers={"A": pts, "B": pts, "C": pts})
    with pytest.raises(NoHeadError, match="head markers not in the file: X.*markers available: A, B, C"):
        load_motion(p, head_markers=["A", "B", "X"])


def test_empty_file_and_unknown_extension(tmp_path):
    for name in ("e.bvh", "e.csv", "e.c3d", "e.json", "e.npz"):
        p = tmp_path / name
        p.write_bytes(b"")
        with pytest.raises(FormatError, match=rf"{name}: file is empty"):
            load_motion(p)
    p = tmp_path / "motion.xyz"
    p.write_text("1 2 3\n")
    with pytest.raises(FormatError, match=r"motion\.xyz: unknown motion file extension '\.xyz'"):
        load_motion(p)
    with pytest.raises(FormatError, match="not found"):
        load_motion(tmp_path / "missing.bvh")
    p = tmp_path / "other.csv"
    p.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(FormatError, match=r"other\.csv, line 1: unrecognised CSV"):
        load_motion(p)
    p = tmp_path / "bad.npz"
    p.write_bytes(b"PK\x03\x04garbage")
    with pytest.raises(FormatError, match=r"bad\.npz"):
        load_motion(p)


def test_npz_refuses_pickles(tmp_path):
    p = tmp_path / "pickled.npz"
    np.savez(p, rotvec=np.zeros((3, 3)), fps=np.float64(10), meta_json=np.array([{"a": 1}], dtype=object))
    with pytest.raises(FormatError, match=r"pickled\.npz"):
        load_motion(p)


def test_writers_leave_no_file_on_failure(tmp_path):
    m = _motion()
    for name, kw in (("x.bvh", {"channel_order": "XYZ"}), ("x.csv", {"euler_order": "ABC"}),
                     ("x.json", {"euler_order": "XYz"}), ("x.csv", {"format": "livelink"}),
                     ("x.npz", {"degrees": True})):
        mm = m.replace(fps=29.97) if kw.get("format") == "livelink" else m
        with pytest.raises(ParameterError):
            save_motion(mm, tmp_path / name, **kw)
    with pytest.raises(FormatError, match="unknown extension"):
        save_motion(m, tmp_path / "x.txt")
    assert list(tmp_path.iterdir()) == []


def test_writer_keeps_old_file_on_failure(tmp_path):
    p = tmp_path / "keep.bvh"
    save_motion(_motion(), p)
    before = p.read_bytes()
    with pytest.raises(ParameterError):
        save_motion(_motion(), p, neck_share=2.0)
    assert p.read_bytes() == before and sorted(x.name for x in tmp_path.iterdir()) == ["keep.bvh"]


# --------------------------------------------------------------------------- examples and CLI
def test_examples_load(examples_dir):
    d = examples_dir / "motion"
    a = load_motion(d / "nod_shake_tilt.bvh")
    b = load_motion(d / "nod_shake_tilt.npz")
    c = load_motion(d / "nod_shake_tilt.csv")
    assert len(a) == len(b) == len(c) == 90 and a.fps == 30.0
    assert _angle_err(a.rotvec, b.rotvec) < 1e-6 and _angle_err(c.rotvec, b.rotvec) < 1e-9
    # first second is a nod: pitch only, peak about 15 degrees
    pyr = np.degrees(b.rotvec[:30])
    assert 13 < np.abs(pyr[:, 0]).max() < 15.01 and np.abs(pyr[:, 1:]).max() < 1e-9


def test_motion_info(examples_dir):
    d = motion_info(examples_dir / "motion" / "nod_shake_tilt.bvh")
    assert d["format"] == "bvh" and d["n_frames"] == 90 and d["fps"] == 30.0
    assert d["joints"] == ["Hips", "Spine", "Neck", "Head"] and d["head_joint"] == "Head"
    assert d["sd_deg"]["pitch"] == pytest.approx(np.degrees(load_motion(
        examples_dir / "motion" / "nod_shake_tilt.npz").rotvec[:, 0].std()), abs=1e-3)


def test_cli_info_and_convert(tmp_path, examples_dir, capsys):
    from headmotion.cli import main

    src = examples_dir / "motion" / "nod_shake_tilt.bvh"
    assert main(["info", str(src)]) == 0
    out = capsys.readouterr().out
    assert "bvh" in out and "90" in out and "30 frames/s" in out and "Head" in out
    assert main(["info", "--json", str(src)]) == 0
    assert json.loads(capsys.readouterr().out)["n_frames"] == 90
    dst = tmp_path / "o.csv"
    assert main(["convert", str(src), str(dst), "--degrees", "--euler-order", "YXZ"]) == 0
    assert dst.read_text().splitlines()[1] == "frame,time,yaw_deg,pitch_deg,roll_deg"
    back = load_motion(dst)
    assert _angle_err(back.rotvec, load_motion(src).rotvec) < 1e-6
    ll = tmp_path / "ll.csv"
    assert main(["convert", str(src), str(ll), "--format", "livelink"]) == 0
    assert load_motion(ll).meta["format"] == "livelink"
    yxz = tmp_path / "y.bvh"
    assert main(["convert", str(dst), str(yxz), "--euler-order", "YXZ", "--fps", "60"]) == 0
    r = load_motion(yxz)
    assert r.fps == 60.0 and len(r) == 180 and "Yrotation Xrotation Zrotation" in yxz.read_text()
    # errors: one line on stderr, non-zero exit, no output file
    bad = tmp_path / "nohead.bvh"
    bad.write_text(_bvh_text(["ZXY"] * 3, [np.zeros(12)], names=("Hips", "Spine", "LeftArm")))
    capsys.readouterr()
    code = main(["convert", str(bad), str(tmp_path / "never.npz")])
    err = capsys.readouterr().err
    assert code != 0 and "nohead.bvh" in err and "no head joint" in err
    assert not (tmp_path / "never.npz").exists()


def test_cli_info_audio(tmp_path, capsys):
    sf = pytest.importorskip("soundfile")
    from headmotion.cli import main

    p = tmp_path / "tone.wav"
    sf.write(p, np.zeros(16000, dtype=np.float32), 16000)
    assert main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert "audio" in out and "16000 Hz" in out and "1.000 s" in out


def test_warning_free_native_load(examples_dir):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_motion(examples_dir / "motion" / "nod_shake_tilt.npz")


def test_motive_euler_rigid_body_and_format_override(tmp_path):
    T, fps = 20, 100.0
    Rh = _track(T, fps, (0.3, 0.5, 0.2), (0.9, 0.6, 1.3), 7)
    p = tmp_path / "euler.txt"
    _motive_csv(p, rigid={"MyHead": (Rh.as_quat(), np.zeros((T, 3)))}, fps=fps)
    # rewrite as Euler XYZ degrees (Rotation Type XYZ, three Rotation columns X, Y, Z)
    lines = p.read_text().splitlines()
    lines[0] = lines[0].replace("Rotation Type,Quaternion", "Rotation Type,XYZ")
    e = Rh.as_euler("XYZ", degrees=True)
    for k in range(2, 7):
        cells = lines[k].split(",")
        del cells[5]  # drop the W column
        lines[k] = ",".join(cells)
    for t in range(T):
        cells = lines[7 + t].split(",")
        cells[2:6] = [f"{v:.9f}" for v in e[t]]
        lines[7 + t] = ",".join(cells)
    p.write_text("\n".join(lines) + "\n")
    m = load_motion(p, format="optitrack")  # .txt: only readable with the format override
    assert m.meta["head"] == "MyHead" and m.meta["relative_to"] == "world"
    assert _angle_err(m.rotvec, Rh.as_rotvec()) < 1e-7
