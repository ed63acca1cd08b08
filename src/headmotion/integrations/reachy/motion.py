"""Head motion made fit for a Reachy Mini, without the robot's SDK: the axes, the limits, the
command rate.

* :func:`robot_pose` / :func:`pitch_yaw_roll_of` — headmotion's pitch, yaw, roll (degrees, intrinsic
  yaw → pitch → roll, :mod:`headmotion.rotations`) to the 4×4 head pose the SDK's
  ``ReachyMini.set_target(head=...)`` takes, and back.  The robot's head frame has x forward, y to
  the robot's left and z up (the SDK's ``look_at_world_pose`` aims +x; its camera looks along +x);
  headmotion's has x to the left, y up and z forward, so the robot's rotation is ``P R Pᵀ`` with
  ``P`` = :data:`ROBOT_FROM_HEADMOTION`.  Both turn the nose down for positive pitch, to the left
  for positive yaw, and tilt the top of the head to the right shoulder for positive roll.
* :class:`HeadLimits` and :class:`Limiter` — the range (a soft clamp: unchanged up to ``knee`` of
  each limit, then easing towards the limit without reaching it) and the speed (each command
  moves at most ``speed / rate`` degrees from the last one, so the head never jumps).
* :class:`Timeline` — the model's frames placed on the wall clock; the pose at any instant by
  linear interpolation, for a command rate above the model's frame rate.
* :class:`PacedFrames` — the frame messages of a voice-agent integration (paced: each when its
  audio plays) onto a timeline.
* :class:`PoseRecord` — the poses sent and what the robot reported, saved as an ``.npz``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import ParameterError

#: robot coordinates (x forward, y left, z up) of headmotion's axes (x left, y up, z forward)
ROBOT_FROM_HEADMOTION = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def rotation_matrix(pyr_deg) -> np.ndarray:
    """``(3, 3)`` rotation of pitch, yaw, roll in degrees, in headmotion's axes: ``Ry(yaw) Rx(pitch)
    Rz(roll)`` (intrinsic ``"YXZ"``, as :func:`headmotion.rotations.pitch_yaw_roll_to_rotvec`)."""
    p, y, r = np.radians(np.asarray(pyr_deg, dtype=np.float64).reshape(3))
    cp, sp, cy, sy, cr, sr = math.cos(p), math.sin(p), math.cos(y), math.sin(y), math.cos(r), math.sin(r)
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]])
    rz = np.array([[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]])
    return ry @ rx @ rz


def pitch_yaw_roll_of_rotation(rot) -> np.ndarray:
    """Pitch, yaw, roll in degrees of a ``(3, 3)`` rotation in headmotion's axes (the inverse of
    :func:`rotation_matrix` for pitch within ±90°)."""
    m = np.asarray(rot, dtype=np.float64)
    pitch = math.asin(max(-1.0, min(1.0, -m[1, 2])))
    yaw = math.atan2(m[0, 2], m[2, 2])
    roll = math.atan2(m[1, 0], m[1, 1])
    return np.degrees([pitch, yaw, roll])


def robot_pose(pyr_deg) -> np.ndarray:
    """The ``(4, 4)`` head pose for ``ReachyMini.set_target(head=...)`` of headmotion's pitch, yaw,
    roll in degrees (the head at its neutral height: no translation)."""
    p = ROBOT_FROM_HEADMOTION
    pose = np.eye(4)
    pose[:3, :3] = p @ rotation_matrix(pyr_deg) @ p.T
    return pose


def pitch_yaw_roll_of(pose) -> np.ndarray:
    """headmotion's pitch, yaw, roll in degrees of a robot head pose (``(4, 4)`` or ``(3, 3)``)."""
    p = ROBOT_FROM_HEADMOTION
    m = np.asarray(pose, dtype=np.float64)
    if m.shape not in ((4, 4), (3, 3)):
        raise ParameterError(f"a head pose is a 4x4 (or 3x3) matrix; got shape {m.shape}")
    return pitch_yaw_roll_of_rotation(p.T @ m[:3, :3] @ p)


def soft_clamp(x, limit: float, knee: float) -> np.ndarray:
    """``x`` unchanged within ``±knee · limit``; beyond, ``k + m·tanh((|x| − k)/m)`` with the sign of
    ``x`` (``k = knee · limit``, ``m = limit − k``): continuous with its slope, monotonic, and
    always inside ``(−limit, limit)``."""
    x = np.asarray(x, dtype=np.float64)
    k = knee * limit
    m = limit - k
    a = np.abs(x)
    if m <= 0:
        return np.clip(x, -limit, limit)
    over = k + m * np.tanh((a - k) / m)
    return np.where(a <= k, x, np.sign(x) * over)


@dataclass(frozen=True)
class HeadLimits:
    """What the robot's head is held to: ``pitch``, ``yaw``, ``roll`` (degrees either side of
    straight ahead; a pose never reaches them), ``speed`` (degrees per second, the length of the
    pitch/yaw/roll step per second) and ``knee`` (the share of each range left unchanged).

    The defaults stay inside the SDK's documented range (pitch and roll ±40°; the head's yaw within
    65° of the body's, past which its inverse kinematics turns the body) and far above the shipped
    models' motion (within ±13°, at most 80°/s on the bundled examples); docs/robots.md says why."""

    pitch: float = 30.0
    yaw: float = 60.0
    roll: float = 30.0
    speed: float = 150.0
    knee: float = 0.75

    def __post_init__(self):
        for name in ("pitch", "yaw", "roll", "speed"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ParameterError(f"{name} limit must be a positive number; got {v!r}")
        if not 0.0 <= self.knee < 1.0:
            raise ParameterError(f"knee must be from 0 to below 1; got {self.knee!r}")

    def clamp(self, pyr_deg) -> np.ndarray:
        """Pitch, yaw, roll held inside the range (:func:`soft_clamp` on each)."""
        x = np.asarray(pyr_deg, dtype=np.float64).reshape(3)
        return np.array([soft_clamp(x[i], lim, self.knee) for i, lim in enumerate((self.pitch, self.yaw, self.roll))])


class Limiter:
    """Each command from a target: the target clamped to the range, then moved towards by at most
    ``speed / rate_hz`` degrees (the direction kept) from the last command."""

    def __init__(self, limits: HeadLimits, rate_hz: float, start=(0.0, 0.0, 0.0)):
        if not rate_hz > 0:
            raise ParameterError(f"the command rate must be positive; got {rate_hz!r}")
        self.limits = limits
        self.max_step = float(limits.speed) / float(rate_hz)
        self.pose = np.asarray(start, dtype=np.float64).reshape(3).copy()

    def step(self, target_pyr_deg) -> np.ndarray:
        d = self.limits.clamp(target_pyr_deg) - self.pose
        n = float(np.linalg.norm(d))
        if n > self.max_step:
            d *= self.max_step / n
        self.pose = self.pose + d
        return self.pose.copy()


class Timeline:
    """Poses (pitch, yaw, roll degrees) at increasing wall-clock times; :meth:`pose_at` interpolates.

    Adding poses that start at or before the last one replaces the poses from there on (a new
    utterance takes over from the last one's settling).  Poses more than ``keep_s`` before the
    last query are dropped."""

    def __init__(self, keep_s: float = 2.0):
        self.keep_s = float(keep_s)
        self.times = np.zeros(0)
        self.poses = np.zeros((0, 3))

    def __len__(self) -> int:
        return len(self.times)

    def add(self, times, pyr_deg) -> None:
        t = np.asarray(times, dtype=np.float64).reshape(-1)
        p = np.asarray(pyr_deg, dtype=np.float64).reshape(-1, 3)
        if len(t) != len(p):
            raise ParameterError(f"{len(t)} times for {len(p)} poses")
        if not len(t):
            return
        if np.any(np.diff(t) <= 0):
            raise ParameterError("the poses' times must increase")
        keep = self.times < t[0]
        self.times = np.concatenate([self.times[keep], t])
        self.poses = np.concatenate([self.poses[keep], p])

    def clear(self) -> None:
        self.times, self.poses = np.zeros(0), np.zeros((0, 3))

    @property
    def end(self) -> float:
        """The last pose's time (−inf when empty)."""
        return float(self.times[-1]) if len(self.times) else -math.inf

    def pose_at(self, t: float):
        """``(pyr_deg, time)``: the pose at ``t`` and the time it belongs to — ``t`` itself between
        two poses, the last pose's time after it (held).  None before the first pose."""
        if not len(self.times) or t < self.times[0]:
            return None
        i = int(np.searchsorted(self.times, t, side="right"))
        if i >= len(self.times):
            out = (self.poses[-1].copy(), float(self.times[-1]))
        else:
            t0, t1 = self.times[i - 1], self.times[i]
            w = (t - t0) / (t1 - t0)
            out = ((1.0 - w) * self.poses[i - 1] + w * self.poses[i], float(t))
        old = int(np.searchsorted(self.times, t - self.keep_s)) - 1
        if old > 0:  # keep one pose before the window: the interpolation needs it
            self.times, self.poses = self.times[old:], self.poses[old:]
        return out


class PacedFrames:
    """Frame messages of ``headmotion serve``'s stream, each arriving when its audio plays (the
    integrations' paced sending), onto a :class:`Timeline`: frame ``n`` of an utterance at
    ``anchor + n / fps + delay_s``.  A paced message is never early, only late (its frames were
    made late, or the sender was busy), so each message implies an anchor ``now − first / fps`` no
    earlier than the true one (from its last frame, the one due nearest to ``now``): the anchor is the earliest of the last ``window`` messages' — it
    moves earlier at once, and later (the playback paused or fell behind) once ``window`` messages
    in a row say so by more than ``tolerance_s``.  ``delay_s`` (default one frame period) lets the
    command rate interpolate up to the newest frame."""

    def __init__(self, timeline: Timeline, *, delay_s: float | None = None, tolerance_s: float = 0.02,
                 window: int = 3):
        from collections import deque

        self.timeline = timeline
        self.delay_s = delay_s
        self.tolerance_s = float(tolerance_s)
        self._implied: deque = deque(maxlen=max(1, int(window)))
        self._key = None
        self._anchor = -math.inf
        self._last = -1

    def message(self, message: dict, now: float) -> None:
        if not isinstance(message, dict) or message.get("type") != "frames" or not message.get("frames"):
            return
        fps = float(message["fps"])
        first = int(message["first"])
        key = message.get("utterance")
        new = key != self._key if key is not None else first <= self._last
        self._key, self._last = key, first + len(message["frames"]) - 1
        if new:
            self._implied.clear()
        self._implied.append(now - self._last / fps)  # the last frame: the one due nearest to now
        anchor = min(self._implied)
        if new or anchor < self._anchor or anchor > self._anchor + self.tolerance_s:
            self._anchor = anchor
        pyr = np.array([f["pitch_yaw_roll_deg"] for f in message["frames"]], dtype=np.float64)
        delay = 1.0 / fps if self.delay_s is None else self.delay_s
        times = self._anchor + (first + np.arange(len(pyr))) / fps + delay
        self.timeline.add(times, pyr)


class PoseRecord:
    """The commands sent and what the robot reported, row by row; :meth:`save` writes an ``.npz``
    atomically: ``time`` (s on the audio clock, 0 when the first sample played: when the command
    went out), ``pose_time`` (the
    audio time the target pose belongs to; NaN while there was none), ``target_deg`` (the motion,
    before the limits), ``sent_deg`` (the command), ``reported_deg`` (the pose the robot reported
    just after it; NaN when none) — pitch, yaw, roll in degrees — and ``rate_hz``, ``limits``
    (pitch, yaw, roll, speed, knee)."""

    FIELDS = ("time", "pose_time", "target_deg", "sent_deg", "reported_deg")

    def __init__(self, rate_hz: float, limits: HeadLimits):
        self.rate_hz, self.limits = float(rate_hz), limits
        self.rows: list[tuple] = []
        #: the wall time of audio time 0 (the first sample played); None: the first command's
        self.origin: float | None = None

    def add(self, time: float, pose_time: float, target, sent, reported) -> None:
        self.rows.append((time, pose_time, target, sent, reported))

    def arrays(self) -> dict:
        n = len(self.rows)
        cols = list(zip(*self.rows)) if n else [[]] * 5
        t = np.asarray(cols[0], dtype=np.float64).reshape(n)
        origin = self.origin if self.origin is not None else (t[0] if n else 0.0)
        out = {"time": t - origin, "pose_time": np.asarray(cols[1], dtype=np.float64).reshape(n) - origin}
        for name, col in zip(self.FIELDS[2:], cols[2:]):
            out[name] = np.asarray(col, dtype=np.float64).reshape(n, 3)
        lim = self.limits
        out["rate_hz"] = np.float64(self.rate_hz)
        out["limits"] = np.array([lim.pitch, lim.yaw, lim.roll, lim.speed, lim.knee])
        return out

    def save(self, path) -> None:
        from ...io.atomic import atomic_path

        with atomic_path(path, suffix=".npz") as tmp:
            np.savez(tmp, **self.arrays())


__all__ = ["ROBOT_FROM_HEADMOTION", "rotation_matrix", "pitch_yaw_roll_of_rotation", "robot_pose",
           "pitch_yaw_roll_of", "soft_clamp", "HeadLimits", "Limiter", "Timeline", "PacedFrames", "PoseRecord"]
