"""Neck and head in the BVH export: the joints compose to the motion, the neck
holds its share, and the default share is the one the ZEGGS mocap take shows."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.io.bvh import DEFAULT_NECK_SHARE, read_bvh_file, save_bvh
from headmotion.motion.neck_share import measure_neck_share
from headmotion.types import Motion


def _motion(fps=30.0, n=120):
    t = np.arange(n) / fps
    rv = np.stack([0.3 + 0.4 * np.sin(2 * np.pi * t), 0.6 * np.sin(np.pi * t + 1), 0.3 * np.cos(1.4 * np.pi * t)], 1)
    return Motion(rv, fps)


@pytest.mark.parametrize("share", [None, 0.0, 0.5, 1.0])
@pytest.mark.parametrize("order", ["ZXY", "YXZ"])
def test_neck_and_head_compose_to_the_motion(tmp_path, share, order):
    m = _motion()
    p = tmp_path / "m.bvh"
    kw = {} if share is None else {"neck_share": share}
    save_bvh(m, p, channel_order=order, **kw)
    s = DEFAULT_NECK_SHARE if share is None else share
    bvh = read_bvh_file(p)
    neck, head = bvh.local_rotations(bvh.index("Neck")), bvh.local_rotations(bvh.index("Head"))
    target = Rotation.from_rotvec(np.array(m.rotvec))
    assert np.max(((neck * head).inv() * target).magnitude()) < 1e-6
    assert np.max((neck.inv() * Rotation.from_rotvec(s * np.asarray(m.rotvec))).magnitude()) < 1e-6
    # the spine and hips stay still
    assert np.max(bvh.local_rotations(bvh.index("Spine")).magnitude()) == 0.0


def test_neck_share_measured_on_zeggs(shared_data):
    r = measure_neck_share(shared_data / "mocap_speech" / "zeggs" / "067_Speech_2_x_1_0.bvh")
    assert r["chain"] == ["Neck", "Neck1", "Head"] and r["frames"] == 2065
    assert r["share"] == pytest.approx(0.93, abs=0.005)
    assert min(r["parts"]) <= DEFAULT_NECK_SHARE <= max(r["parts"])
    assert r["joints"]["Head"] < 0.05  # the head joint itself barely moves on the neck


def test_neck_share_of_our_own_export_is_the_share_written(tmp_path):
    """The estimator recovers the share our writer used (known answer)."""
    p = tmp_path / "m.bvh"
    save_bvh(_motion(n=300), p, neck_share=0.4)
    r = measure_neck_share(p)
    assert r["chain"] == ["Neck", "Head"]
    assert r["share"] == pytest.approx(0.4, abs=0.02)
