"""The robot-independent part of the Reachy Mini integration (:mod:`headmotion.integrations.reachy.motion`),
which needs no SDK: the axes against headmotion's own rotations, the soft range clamp and the
speed limit (known answers; never a jump), the interpolation to the command rate, the paced
agent messages on the clock, and the pose record.  The robot itself: tests/test_integration_reachy.py."""

from __future__ import annotations

import asyncio
import math
import time

import numpy as np
import pytest

from headmotion.errors import MissingDependencyError, ParameterError
from headmotion.integrations.reachy.motion import (
    ROBOT_FROM_HEADMOTION,
    HeadLimits,
    Limiter,
    PacedFrames,
    PoseRecord,
    Timeline,
    pitch_yaw_roll_of,
    robot_pose,
    rotation_matrix,
    soft_clamp,
)
from headmotion.rotations import pitch_yaw_roll_to_rotvec, rotvec_to_matrix


def test_rotation_matrix_is_headmotions_pitch_yaw_roll():
    rng = np.random.default_rng(0)
    for pyr in rng.uniform(-60, 60, size=(20, 3)):
        want = rotvec_to_matrix(pitch_yaw_roll_to_rotvec(*pyr, degrees=True))[0]
        assert np.allclose(rotation_matrix(pyr), want, atol=1e-12)
        assert np.allclose(pitch_yaw_roll_of(robot_pose(pyr)), pyr, atol=1e-9)


def test_robot_axes_known_answers():
    """The robot's head frame: x forward (its gaze), y to its left, z up."""
    assert np.allclose(ROBOT_FROM_HEADMOTION @ [0, 0, 1], [1, 0, 0])  # forward
    assert np.allclose(ROBOT_FROM_HEADMOTION @ [1, 0, 0], [0, 1, 0])  # left
    assert np.allclose(ROBOT_FROM_HEADMOTION @ [0, 1, 0], [0, 0, 1])  # up
    nose, up = (lambda m: m[:3, 0]), (lambda m: m[:3, 2])
    down = robot_pose((10, 0, 0))  # positive pitch: the nose goes down
    assert nose(down)[2] == pytest.approx(-math.sin(math.radians(10)))
    left = robot_pose((0, 10, 0))  # positive yaw: the nose turns to the robot's left (+y)
    assert nose(left)[1] == pytest.approx(math.sin(math.radians(10)))
    right = robot_pose((0, 0, 10))  # positive roll: the top of the head to the right shoulder (−y)
    assert up(right)[1] == pytest.approx(-math.sin(math.radians(10)))
    # the SDK's create_head_pose(roll, pitch, yaw) is R.from_euler("xyz", [roll, pitch, yaw]) in its
    # frame: for one axis at a time, its pitch is about y, its yaw about z and its roll about x
    c, s = math.cos(math.radians(10)), math.sin(math.radians(10))
    assert np.allclose(down[:3, :3], [[c, 0, s], [0, 1, 0], [-s, 0, c]])
    assert np.allclose(left[:3, :3], [[c, -s, 0], [s, c, 0], [0, 0, 1]])
    assert np.allclose(right[:3, :3], [[1, 0, 0], [0, c, -s], [0, s, c]])
    assert np.allclose(robot_pose((0, 0, 0)), np.eye(4))


def test_soft_clamp_known_answers_and_smoothness():
    assert soft_clamp(10.0, 40.0, 0.75) == 10.0  # below the knee: unchanged
    assert soft_clamp(30.0, 40.0, 0.75) == 30.0  # at the knee
    assert soft_clamp(40.0, 40.0, 0.75) == pytest.approx(30 + 10 * math.tanh(1.0))  # 37.6159
    assert soft_clamp(-1e6, 40.0, 0.75) == pytest.approx(-40.0)
    assert abs(soft_clamp(1e300, 40.0, 0.75)) <= 40.0
    x = np.linspace(-80, 80, 16001)
    y = soft_clamp(x, 40.0, 0.75)
    assert np.all(np.abs(y) < 40.0) and np.all(np.diff(y) > 0)  # inside, increasing
    slope = np.diff(y) / np.diff(x)
    assert slope.max() <= 1 + 1e-9 and np.abs(np.diff(slope)).max() < 1e-3  # continuous slope: no kink
    assert np.allclose(soft_clamp(x, 40.0, 0.0), 40 * np.tanh(x / 40))


def test_limiter_speed_known_answer_and_never_a_jump():
    lim = Limiter(HeadLimits(speed=180.0), rate_hz=50.0)  # 3.6° a command at most
    steps = [lim.step((10.0, 0.0, 0.0))[0] for _ in range(4)]
    assert steps == pytest.approx([3.6, 7.2, 10.0, 10.0])
    lim = Limiter(HeadLimits(speed=100.0), rate_hz=50.0)  # 2° a command, the direction kept
    assert lim.step((3.0, 4.0, 0.0)) == pytest.approx([1.2, 1.6, 0.0])
    rng = np.random.default_rng(1)  # any target, however wild: every step within the limit, inside the range
    lims = HeadLimits()
    lim = Limiter(lims, rate_hz=50.0, start=(5.0, -3.0, 1.0))
    out = np.array([lim.step(t) for t in rng.uniform(-120, 120, size=(500, 3))])
    assert np.linalg.norm(np.diff(out, axis=0), axis=1).max() <= lims.speed / 50.0 + 1e-9
    assert np.all(np.abs(out) < [lims.pitch, lims.yaw, lims.roll])


def test_limiter_leaves_motion_within_the_limits_unchanged():
    t = np.arange(0, 4, 0.02)
    motion = np.stack([8 * np.sin(2 * np.pi * 0.7 * t), 12 * np.sin(2 * np.pi * 0.3 * t), 5 * np.cos(t)], axis=1)
    lim = Limiter(HeadLimits(), rate_hz=50.0, start=motion[0])
    assert np.allclose([lim.step(m) for m in motion], motion, atol=1e-12)


def test_limits_refuse_bad_values():
    with pytest.raises(ParameterError):
        HeadLimits(speed=0)
    with pytest.raises(ParameterError):
        HeadLimits(pitch=float("nan"))
    with pytest.raises(ParameterError):
        HeadLimits(knee=1.0)
    with pytest.raises(ParameterError):
        Limiter(HeadLimits(), rate_hz=0)


def test_timeline_interpolates_at_the_command_rate():
    tl = Timeline()
    assert tl.pose_at(0.0) is None
    frames = np.array([[0, 0, 0], [4, -2, 1], [8, 0, 3]], dtype=float)
    tl.add(10.0 + np.arange(3) / 25.0, frames)  # 25 frames a second
    assert tl.pose_at(9.99) is None  # before the first frame: nothing (the head holds its pose)
    pose, at = tl.pose_at(10.0 + 0.02)  # half-way between frames 0 and 1
    assert pose == pytest.approx([2, -1, 0.5]) and at == pytest.approx(10.02)
    pose, at = tl.pose_at(10.07)  # three quarters between frames 1 and 2
    assert pose == pytest.approx([7, -0.5, 2.5])
    pose, at = tl.pose_at(11.0)  # after the last: held, and it says which time it is
    assert pose == pytest.approx(frames[-1]) and at == pytest.approx(10.08)


def test_timeline_new_poses_replace_the_later_ones():
    tl = Timeline()
    tl.add([1.0, 1.1, 1.2, 1.3], np.ones((4, 3)))
    tl.add([1.15, 1.25], np.full((2, 3), 5.0))  # a new utterance takes over from the settling
    assert list(tl.times) == pytest.approx([1.0, 1.1, 1.15, 1.25])
    with pytest.raises(ParameterError):
        tl.add([2.0, 2.0], np.zeros((2, 3)))


def _frames(first, pyr, **extra):
    return {"type": "frames", "first": first, "fps": 25.0, "audio_time": 0.0,
            "frames": [{"frame": first + k, "time": (first + k) / 25.0, "rotvec": [0, 0, 0],
                        "pitch_yaw_roll_deg": list(map(float, p))} for k, p in enumerate(pyr)], **extra}


def test_paced_frames_go_on_at_their_audio_time_plus_one_frame():
    tl = Timeline()
    paced = PacedFrames(tl)
    # frames 0-12 were made late and go out together when frame 12 is due: placed by the last one
    paced.message(_frames(0, [[1, 0, 0]] * 13, utterance=1), now=100.49)
    assert tl.times[0] == pytest.approx(100.01 + 0.04) and tl.times[-1] == pytest.approx(100.53)
    paced.message(_frames(13, [[2, 0, 0]], utterance=1), now=100.521)  # on time: the anchor moves earlier
    assert tl.times[-1] == pytest.approx(100.561 - 0.0) and len(tl) == 14
    paced.message(_frames(14, [[3, 0, 0]], utterance=1), now=100.6)  # one late message: no new anchor
    assert tl.times[-1] == pytest.approx(100.601)
    for k, now in enumerate([100.75, 100.79, 100.83]):  # late again and again (a pause): the anchor follows
        paced.message(_frames(15 + k, [[4, 0, 0]], utterance=1), now=now)
    assert tl.times[-1] == pytest.approx(100.87)
    paced.message(_frames(0, [[9, 9, 9]], utterance=2), now=100.8)  # the next utterance: anchored anew,
    assert tl.times[-1] == pytest.approx(100.84) and tl.times[-2] < 100.84  # replacing what was after it
    n = len(tl)
    paced.message({"type": "end", "frames": 1, "audio_seconds": 0.1}, now=100.9)  # other messages: nothing
    paced.message({"type": "audio-start", "utterance": 3}, now=100.9)
    assert len(tl) == n


def test_paced_agent_frames_follow_the_pacer(examples_dir):
    """The integrations' own pacing (Pacer + PacedSender, as in Pipecat and LiveKit) into a
    timeline: each frame is on the timeline one frame period after its audio plays, within the
    sender's jitter, and the poses are the core's."""
    from headmotion.io import load_audio
    from headmotion.live.core import HeadMotionCore
    from headmotion.live.pacing import PacedSender, Pacer
    from headmotion.rotations import rotvec_to_pitch_yaw_roll

    speech = load_audio(examples_dir / "speech" / "short.wav")
    x, rate = speech.samples[: int(1.2 * speech.sample_rate)], speech.sample_rate
    core = HeadMotionCore("stream", settle_s=0.2)
    core.push(x[:rate // 2], rate)  # warm: the first stream's first pushes are slow
    core.interrupt()
    pacer = Pacer(core)
    tl = Timeline(keep_s=60.0)
    paced = PacedFrames(tl)
    made = []

    async def main():
        async def send(message):
            paced.message(message, time.monotonic())

        sender = PacedSender(pacer, send)
        sender.start()
        step = rate // 50
        for i in range(0, len(x), step):
            made.append(pacer.audio(x[i:i + step], rate).rotvec)
            sender.wake()
            await asyncio.sleep(step / rate * 0.5)  # a TTS faster than real time
        pacer.end()
        sender.wake()
        assert await sender.wait_idle(timeout=10.0)
        await sender.aclose()

    asyncio.run(main())
    frames = np.vstack([m for m in made if len(m)])
    pyr = rotvec_to_pitch_yaw_roll(frames, degrees=True)
    assert np.allclose(tl.poses[:len(pyr)], pyr, atol=1e-3)  # the core's frames (JSON-rounded)
    played = np.array([pacer._wall(n / 25.0) for n in range(len(pyr))])  # when the pacer played each frame's audio
    late = tl.times[:len(pyr)] - (played + 1 / 25.0)
    # the first frames are made 40 ms after their audio time (the model's latency; the audio comes at
    # twice real time here): they go out late, the others on time
    assert np.all(late > -0.002) and np.median(late) < 0.01 and np.all(late[3:] < 0.03), late


def test_pose_record_saves_atomically(tmp_path):
    rec = PoseRecord(50.0, HeadLimits())
    rec.origin = 10.0
    rec.add(10.02, 10.0, [1, 2, 3], [1, 2, 3], [1.01, 2, 3])
    rec.add(10.04, math.nan, [1, 2, 3], [1, 2, 3], [math.nan] * 3)
    path = tmp_path / "poses.npz"
    rec.save(path)
    with np.load(path) as z:
        assert sorted(z.files) == ["limits", "pose_time", "rate_hz", "reported_deg", "sent_deg", "target_deg", "time"]
        assert z["time"] == pytest.approx([0.02, 0.04]) and z["pose_time"][0] == pytest.approx(0.0)
        assert np.isnan(z["pose_time"][1]) and z["sent_deg"].shape == (2, 3)
        assert list(z["limits"]) == [30.0, 60.0, 30.0, 150.0, 0.75] and float(z["rate_hz"]) == 50.0
    assert [p.name for p in tmp_path.iterdir()] == ["poses.npz"]  # no temporary file left


def test_the_robot_needs_its_sdk_and_says_how_to_install_it():
    try:
        import reachy_mini  # noqa: F401
    except ImportError:
        pass
    else:
        pytest.skip("reachy_mini is installed here")
    with pytest.raises(MissingDependencyError, match=r'pip install "headmotion\[reachy\]"'):
        from headmotion.integrations.reachy import ReachyHead  # noqa: F401


def test_the_command_without_the_sdk_is_one_line(examples_dir):
    import subprocess
    import sys

    try:
        import reachy_mini  # noqa: F401
    except ImportError:
        pass
    else:
        pytest.skip("reachy_mini is installed here")
    r = subprocess.run([sys.executable, "-m", "headmotion", "robot", "reachy", str(examples_dir / "speech" / "short.wav")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 3
    assert r.stderr.strip().splitlines() == [
        "error: the Reachy Mini integration needs the robot's SDK (No module named 'reachy_mini'); install it "
        "with: pip install \"headmotion[reachy]\""]
