"""OpenFace CSVs written the way FeatureExtraction writes them: millisecond
timestamps, both layouts, success = 0 frames and rows left out as gaps, bad timestamps."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.errors import FormatError, HeadMotionError, ParameterError
from headmotion.io.motion import load_motion, motion_info
from headmotion.io.openface import snap_rate

OLD_COLS = ["frame", "timestamp", "confidence", "success", "gaze_0_x", "gaze_0_y", "gaze_0_z",
            "pose_Tx", "pose_Ty", "pose_Tz", "pose_Rx", "pose_Ry", "pose_Rz"]
NEW_COLS = ["frame", "face_id", "timestamp", "confidence", "success", "gaze_0_x", "gaze_0_y", "gaze_0_z",
            "pose_Tx", "pose_Ty", "pose_Tz", "pose_Rx", "pose_Ry", "pose_Rz"]


def write_openface(path, angles, fps, *, layout="2.x", success=None, keep=None, t0=0.0):
    """Write ``angles (T, 3)`` (pose_Rx, Ry, Rz in radians) as OpenFace does: timestamp with 3
    decimals, frame numbers from 1, 1.x with ", " separators, 2.x with a face_id column."""
    T = len(angles)
    success = np.ones(T, bool) if success is None else np.asarray(success, bool)
    keep = np.ones(T, bool) if keep is None else np.asarray(keep, bool)
    cols = NEW_COLS if layout == "2.x" else OLD_COLS
    sep = "," if layout == "2.x" else ", "
    lines = [sep.join(cols)]
    for i in range(T):
        if not keep[i]:
            continue
        ok = success[i]
        rx, ry, rz = angles[i] if ok else (0.0, 0.0, 0.0)
        vals = {"frame": f"{i + 1}", "face_id": "0", "timestamp": f"{t0 + i / fps:.3f}",
                "confidence": "0.98" if ok else "0", "success": "1" if ok else "0",
                "gaze_0_x": "0.1", "gaze_0_y": "0.2", "gaze_0_z": "-0.97",
                "pose_Tx": "12.3" if ok else "0", "pose_Ty": "-4.5" if ok else "0", "pose_Tz": "520.1" if ok else "0",
                "pose_Rx": f"{rx:.3f}", "pose_Ry": f"{ry:.3f}", "pose_Rz": f"{rz:.3f}"}
        lines.append(sep.join(vals[c] for c in cols))
    path.write_text("\n".join(lines) + "\n")
    return path


def _angles(T, fps):
    t = np.arange(T) / fps
    return np.stack([0.1 * np.sin(2 * np.pi * 0.3 * t), 0.2 * np.sin(2 * np.pi * 0.2 * t + 1),
                     0.05 * np.sin(2 * np.pi * 0.5 * t)], 1)


@pytest.mark.parametrize("layout", ["1.x", "2.x"])
@pytest.mark.parametrize("fps", [23.976, 25.0, 29.97, 30.0, 60.0])
def test_rate_from_span_is_the_true_rate(tmp_path, layout, fps):
    T = int(round(20 * fps))
    m = load_motion(write_openface(tmp_path / "of.csv", _angles(T, fps), fps, layout=layout))
    assert m.fps == fps and len(m) == T and m.meta["layout"] == layout
    assert abs(m.duration - T / fps) < 1e-9


def test_short_file_snaps_within_ms_rounding(tmp_path):
    # 3 frames at 60 fps: 0.000, 0.017, 0.033 → 2 / 0.033 = 60.6 fps (1 % off, within the 3 %
    # that millisecond rounding allows over 0.033 s), snapped to 60
    m = load_motion(write_openface(tmp_path / "of.csv", _angles(3, 60), 60.0))
    assert m.fps == 60.0


def test_non_standard_rate_is_kept(tmp_path):
    fps = 22.13  # a variable-rate phone clip's average
    m = load_motion(write_openface(tmp_path / "of.csv", _angles(400, fps), fps))
    assert m.fps == pytest.approx(fps, rel=1e-4) and m.fps != 24.0


def test_snap_rate():
    assert snap_rate(30.303) == 30.303  # 1 % off: not snapped without a span
    assert snap_rate(30.1) == 30.0 and snap_rate(29.96) == 29.97 and snap_rate(24.02) == 24.0
    assert snap_rate(30.303, span=0.099) == 30.0  # 3 frames, ms rounding


def test_success_zero_and_missing_rows_are_gaps(tmp_path):
    fps, T = 30.0, 300
    ang = _angles(T, fps)
    success = np.ones(T, bool)
    success[100:103] = False  # three failed frames
    keep = np.ones(T, bool)
    keep[200:202] = False  # two rows left out of the file
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # short gaps: no warning
        m = load_motion(write_openface(tmp_path / "of.csv", ang, fps, success=success, keep=keep))
    assert len(m) == T and m.fps == fps
    assert m.meta["gaps"]["filled_frames"] == 5 and m.meta["gaps"]["short_gaps"] == 2
    expect = Rotation.from_euler("XYZ", ang * [1, -1, -1]).as_rotvec()
    good = success & keep
    np.testing.assert_allclose(m.rotvec[good], expect[good], atol=2e-3)  # 3-decimal angles
    # the interpolated frames lie on the smooth curve
    np.testing.assert_allclose(m.rotvec[~good], expect[~good], atol=5e-3)


def test_long_gap_is_reported(tmp_path):
    fps, T = 25.0, 250
    success = np.ones(T, bool)
    success[50:80] = False  # 1.2 s without a face
    with pytest.warns(UserWarning, match="longer than"):
        m = load_motion(write_openface(tmp_path / "of.csv", _angles(T, fps), fps, success=success))
    assert m.meta["gaps"]["long_gaps"] == [[2.0, 3.2]]


def test_timestamps_going_backwards_is_an_error(tmp_path):
    p = write_openface(tmp_path / "of.csv", _angles(10, 30), 30.0)
    lines = p.read_text().splitlines()
    f = lines[6].split(",")
    f[2] = "0.010"  # frame 6 stamped before frame 5
    lines[6] = ",".join(f)
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError, match=r"of\.csv, line 7: timestamp goes backwards \(0\.133 then 0\.01\)"):
        load_motion(p)


def test_frames_going_backwards_is_an_error(tmp_path):
    p = write_openface(tmp_path / "of.csv", _angles(10, 30), 30.0, layout="1.x")
    lines = p.read_text().splitlines()
    lines[4] = "2" + lines[4][1:]
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(FormatError, match="line 5: frame goes backwards"):
        load_motion(p)


def test_no_rate_and_bad_rate(tmp_path):
    p = tmp_path / "still.csv"
    p.write_text("frame,face_id,timestamp,confidence,success,pose_Rx,pose_Ry,pose_Rz\n"
                 "1,0,0.000,0.9,1,0.1,0.1,0.1\n2,0,0.000,0.9,1,0.1,0.1,0.1\n")
    with pytest.raises(FormatError, match="cannot infer the frame rate.*pass fps="):
        load_motion(p)
    assert load_motion(p, fps=30).fps == 30.0
    for bad in (0, -5, float("nan"), 5000):
        with pytest.raises(ParameterError, match="still.csv: fps= .* is not a finite rate between 1 and 1000"):
            load_motion(p, fps=bad)
    q = tmp_path / "fast.csv"  # 1 µs steps in 3 decimals cannot be; frames 1 ms apart over 0.002 s → 1000 ok
    q.write_text("frame,timestamp,success,pose_Rx,pose_Ry,pose_Rz\n1,0.000,1,0,0,0\n3000,0.001,1,0,0,0\n")
    with pytest.raises(FormatError, match="frame rate of 2.999e\\+06 fps|frame numbers jump"):
        load_motion(q)


def test_nan_pose_is_a_gap(tmp_path):
    p = write_openface(tmp_path / "of.csv", _angles(60, 30), 30.0)
    lines = p.read_text().splitlines()
    f = lines[10].split(",")
    f[-3] = "nan"
    lines[10] = ",".join(f)
    p.write_text("\n".join(lines) + "\n")
    m = load_motion(p)
    assert len(m) == 60 and m.meta["gaps"]["filled_frames"] == 1


def test_info_reports_rate(tmp_path):
    info = motion_info(write_openface(tmp_path / "of.csv", _angles(600, 30), 30.0, layout="1.x"))
    assert info["format"] == "openface" and info["fps"] == 30.0 and info["n_frames"] == 600


def test_every_failure_is_a_headmotion_error(tmp_path):
    p = tmp_path / "h.csv"
    p.write_text("frame, timestamp, success, pose_Rx, pose_Ry, pose_Rz\n")
    with pytest.raises(HeadMotionError, match="no frames"):
        load_motion(p)
    p.write_text("frame, timestamp, success, pose_Rx, pose_Ry, pose_Rz\n1, 0.000, 1, x, 0, 0\n")
    with pytest.raises(FormatError, match="line 2: pose_Rx = 'x' is not a number"):
        load_motion(p)


def test_corpus_fps_column_overrides_the_file_rate(tmp_path):
    from headmotion.corpus import Corpus
    from headmotion.io import save_audio
    from headmotion.types import Audio

    fps, T = 25.0, 250
    p = write_openface(tmp_path / "take.csv", _angles(T, fps), fps)
    # an image sequence: OpenFace writes no usable timestamps
    lines = p.read_text().splitlines()
    lines = [lines[0]] + [",".join(f if k != 2 else "0.000" for k, f in enumerate(l.split(","))) for l in lines[1:]]
    p.write_text("\n".join(lines) + "\n")
    t = np.arange(int(T / fps * 16000)) / 16000
    save_audio(Audio(0.1 * np.sin(2 * np.pi * 150 * t), 16000), tmp_path / "take.wav")
    (tmp_path / "corpus.csv").write_text("recording,speaker,task,audio,motion\nt1,s,read,take.wav,take.csv\n")
    with pytest.raises(FormatError, match="cannot infer the frame rate"):
        Corpus.load(tmp_path)[0]
    (tmp_path / "corpus.csv").write_text("recording,speaker,task,audio,motion,fps\nt1,s,read,take.wav,take.csv,25\n")
    c = Corpus.load(tmp_path)
    r = c[0]
    assert r.motion.fps == 25.0 and len(r.motion) == T and c.entries[0].fps == 25.0
    c.save(tmp_path / "copy")  # the column survives a save (files written natively)
    assert Corpus.load(tmp_path / "copy")[0].motion.fps == 25.0
    c2 = Corpus.load(tmp_path)
    c2.save()
    assert "fps" in (tmp_path / "corpus.csv").read_text().splitlines()[0]
    (tmp_path / "corpus.csv").write_text("recording,speaker,task,audio,motion,fps\nt1,s,read,take.wav,take.csv,fast\n")
    with pytest.raises(FormatError, match=r"corpus\.csv, line 2: fps must be a number within 1–1000"):
        Corpus.load(tmp_path)


def test_corpus_fps_column_retimes_a_file_with_its_own_rate(tmp_path):
    from headmotion.corpus import Corpus
    from headmotion.io import save_audio, save_motion
    from headmotion.types import Audio, Motion

    rv = 0.1 * np.sin(np.linspace(0, 6, 250))[:, None] * np.ones(3)
    save_motion(Motion(rv, 30.0), tmp_path / "take.bvh")  # a BVH that states the wrong rate
    save_audio(Audio(np.zeros(16000 * 10), 16000), tmp_path / "take.wav")
    (tmp_path / "corpus.csv").write_text("recording,speaker,task,audio,motion,fps\nt,s,read,take.wav,take.bvh,25\n")
    r = Corpus.load(tmp_path)[0]
    assert r.motion.fps == 25.0 and len(r.motion) == 250 and r.motion.meta["fps_from"] == "corpus.csv"
    np.testing.assert_allclose(r.motion.rotvec, rv, atol=1e-6)
