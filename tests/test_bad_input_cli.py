"""Bad input files through the CLI: each a clear one-line error naming the file (or,
for the video case, see tests/test_video_cuts_real.py: a recording with the gap marked)."""

from __future__ import annotations

import numpy as np

from headmotion.cli import main

BVH_NO_HEAD = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LeftArm
    {
      OFFSET 5 5 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 5 0 0
      }
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.033333
0 0 0 0 0 0 0 0 0 1 2 3
0 0 0 0 0 0 0 0 0 1 2 3
"""


def _one_line_error(capsys, rc, *needles):
    err = capsys.readouterr().err
    assert rc != 0
    assert "Traceback" not in err
    text = " ".join(err.split())  # rich may wrap a long line
    for n in needles:
        assert n in text, (n, err)


def test_openface_timestamps_backwards(tmp_path, capsys):
    p = tmp_path / "of.csv"
    p.write_text("frame, timestamp, confidence, success, pose_Rx, pose_Ry, pose_Rz\n"
                 "1, 0.000, 0.9, 1, 0, 0, 0\n2, 0.033, 0.9, 1, 0, 0, 0\n3, 0.020, 0.9, 1, 0, 0, 0\n")
    _one_line_error(capsys, main(["convert", str(p), str(tmp_path / "o.bvh")]),
                    "of.csv, line 4", "timestamp goes backwards")


def test_npz_poses_of_the_wrong_width(tmp_path, capsys):
    p = tmp_path / "take.npz"
    np.savez(p, poses=np.zeros((10, 69)), mocap_frame_rate=30.0)
    _one_line_error(capsys, main(["convert", str(p), str(tmp_path / "o.bvh")]),
                    "take.npz", "'poses' has shape (10, 69)", "(frames, 165) SMPL-X")
    np.savez(p, poses=np.zeros((10, 165)))
    _one_line_error(capsys, main(["convert", str(p), str(tmp_path / "o.bvh")]), "take.npz", "no frame rate")


def test_bvh_with_no_head_joint(tmp_path, capsys):
    p = tmp_path / "nohead.bvh"
    p.write_text(BVH_NO_HEAD)
    _one_line_error(capsys, main(["convert", str(p), str(tmp_path / "o.npz")]), "nohead.bvh", "head")
    # info still describes the file and says why there is no head motion
    assert main(["info", str(p)]) == 0
    assert "unavailable" in " ".join(capsys.readouterr().out.split())
