"""A Reachy Mini's head following head motion: :class:`ReachyHead` (needs the ``reachy-mini`` SDK).

A thread sends ``ReachyMini.set_target(head=pose)`` at the command rate (default 50 Hz, the
daemon's control loop): the pose of the :class:`~.motion.Timeline` at that instant, held to the
range and the speed of :class:`~.motion.HeadLimits` (:class:`~.motion.Limiter`), then reads the
pose the daemon reports.  What fills the timeline:

* :meth:`ReachyHead.place` — frames of a :class:`~headmotion.live.core.HeadMotionCore` at known
  wall times (:mod:`.play`: a speech file played, the microphone);
* :meth:`ReachyHead.send` — ``async send(message)`` for a voice-agent integration's paced frame
  messages (``HeadMotionProcessor(send=head.send)``, ``attach_head_motion(session, send=head.send)``).

:meth:`ReachyHead.settle` eases the head to rest from where it is, with its own speed at first
(:func:`headmotion.live.core.settle_path`); :meth:`ReachyHead.stop` settles and stops.  A daemon
that is not there, or goes away, is a :class:`~headmotion.errors.NetworkError` (one line).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

import numpy as np

from ...errors import MissingDependencyError, NetworkError

try:
    from reachy_mini import ReachyMini
    from websockets.exceptions import WebSocketException
except ImportError as exc:  # pragma: no cover - exercised where the SDK is missing
    raise MissingDependencyError(
        f"the Reachy Mini integration needs the robot's SDK ({exc}); install it with: "
        "pip install \"headmotion[reachy]\"") from exc

from .motion import HeadLimits, Limiter, PacedFrames, PoseRecord, Timeline, pitch_yaw_roll_of, robot_pose

#: the daemon's control loop rate (its backends' ``control_loop_frequency``): the default command rate
DEFAULT_RATE_HZ = 50.0
#: what a lost daemon raises in the SDK's client
_LOST = (ConnectionError, TimeoutError, OSError, WebSocketException)
_LOCAL = ("localhost", "127.0.0.1", "::1")


def connect(host: str = "localhost", port: int = 8000, *, media: bool = False, timeout_s: float = 5.0):
    """A ``ReachyMini`` connected to the daemon at ``host:port`` (its media only with ``media``).
    Raises :class:`~headmotion.errors.NetworkError` when no daemon answers within ``timeout_s``."""
    mode = "localhost_only" if host in _LOCAL else "network"
    try:
        return ReachyMini(host=host, port=int(port), connection_mode=mode, timeout=float(timeout_s),
                          media_backend="default" if media else "no_media")
    except _LOST as exc:
        raise NetworkError(f"no Reachy Mini daemon answered at {host}:{port} ({exc}); start it "
                           "(reachy-mini-daemon) or give its --host and --port") from None
    except Exception as exc:
        if not media:
            raise
        from ...errors import AudioDeviceError

        raise AudioDeviceError(f"the robot's audio at {host}:{port} could not be opened ({type(exc).__name__}: "
                               f"{exc})") from None


class ReachyHead:
    """The robot's head following the motion given to it (module docstring).

    Parameters
    ----------
    robot : ReachyMini, optional
        A connected robot (kept open at :meth:`close`); None: connect to ``host:port``.
    rate_hz : float
        Commands per second (the model's frames are interpolated in between).
    limits : HeadLimits
        Range and speed.
    rest : (pitch, yaw, roll) degrees
        Where :meth:`settle` takes the head, and where it goes first.
    record : bool
        Keep every command (:attr:`record`, :class:`~.motion.PoseRecord`).
    media : bool
        Open the robot's media (its speaker: :class:`~.audio.RobotSpeaker`) when connecting.
    timeout_s : float
        How long to wait for the daemon when connecting.
    settle_s : float
        :meth:`settle`'s default duration.
    clock : callable
        Monotonic seconds; the times given to :meth:`place` are on it.
    """

    def __init__(self, robot=None, *, host: str = "localhost", port: int = 8000, rate_hz: float = DEFAULT_RATE_HZ,
                 limits: HeadLimits | None = None, rest=(0.0, 0.0, 0.0), record: bool = False,
                 media: bool = False, timeout_s: float = 5.0, settle_s: float = 0.5,
                 clock: Callable[[], float] = time.monotonic):
        self.limits = limits or HeadLimits()
        self.rate_hz = float(rate_hz)
        if not 1.0 <= self.rate_hz <= 200.0:
            from ...errors import ParameterError

            raise ParameterError(f"the command rate must be from 1 to 200 Hz; got {rate_hz!r}")
        self.where = f"{host}:{port}"
        self._owned = robot is None
        self.robot = connect(host, port, media=media, timeout_s=timeout_s) if robot is None else robot
        self.clock = clock
        self.rest = np.asarray(rest, dtype=np.float64).reshape(3)
        self.settle_s = float(settle_s)
        self.timeline = Timeline()
        self.paced = PacedFrames(self.timeline)
        self.record = PoseRecord(self.rate_hz, self.limits) if record else None
        self.error: NetworkError | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._target = self.rest.copy()
        self._sent: list[np.ndarray] = []
        self.limiter: Limiter | None = None
        #: commands sent so far
        self.commands = 0

    # -- the command loop ------------------------------------------------------------------

    def start(self) -> ReachyHead:
        """Read where the head is and start the commands from there (once); a head off its neutral
        height (asleep) is lifted to rest first (:meth:`_lift`)."""
        if self._thread is not None:
            return self
        try:
            pose = np.asarray(self.robot.get_current_head_pose(), dtype=np.float64)
        except _LOST as exc:
            raise self._lost(exc) from None
        start = pitch_yaw_roll_of(pose)
        if np.linalg.norm(pose[:3, 3]) > 0.005:  # off its neutral height (asleep): lifted first
            try:
                self._lift(pose)
            except _LOST as exc:
                raise self._lost(exc) from None
            start = self.rest
        self.limiter = Limiter(self.limits, self.rate_hz, start=start)
        self._thread = threading.Thread(target=self._run, name="headmotion-reachy", daemon=True)
        self._thread.start()
        return self

    def _lift(self, pose, seconds: float = 1.0) -> None:
        """From ``pose`` (a head off its neutral height, e.g. asleep) to the rest pose at its height:
        a minimum-jerk move of the whole pose over ``seconds``, sent at the command rate (as the
        SDK's own ``goto_target`` would, without its task)."""
        pyr0, xyz0 = pitch_yaw_roll_of(pose), np.asarray(pose, dtype=np.float64)[:3, 3]
        n = max(1, int(round(seconds * self.rate_hz)))
        t0 = self.clock()
        for k in range(1, n + 1):
            s = k / n
            w = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
            pyr = pyr0 + w * (self.rest - pyr0)
            target = robot_pose(pyr)
            target[:3, 3] = (1.0 - w) * xyz0
            self.robot.set_target(head=target)
            if self.record is not None:
                self.record.add(self.clock(), math.nan, pyr, pyr, pitch_yaw_roll_of(self.robot.get_current_head_pose()))
            self.commands += 1
            time.sleep(max(0.0, t0 + k / self.rate_hz - self.clock()))

    def _lost(self, exc) -> NetworkError:
        return NetworkError(f"the Reachy Mini daemon at {self.where} went away ({type(exc).__name__}: {exc})")

    def _run(self) -> None:
        period = 1.0 / self.rate_hz
        due = self.clock()
        while not self._stop.is_set():
            now = self.clock()
            with self._lock:
                got = self.timeline.pose_at(now)
            pose_time = math.nan
            if got is not None:
                self._target, pose_time = got
            sent = self.limiter.step(self._target)
            try:
                self.robot.set_target(head=robot_pose(sent))
                sent_at = self.clock()
                reported = pitch_yaw_roll_of(self.robot.get_current_head_pose())
            except _LOST as exc:
                self.error = self._lost(exc)
                return
            self._sent = [self._sent[-1], sent] if self._sent else [sent]
            self.commands += 1
            if self.record is not None:
                self.record.add(sent_at, pose_time, self._target.copy(), sent, reported)
            due += period
            wait = due - self.clock()
            if wait < -period:  # fell behind (a stall): go on from now rather than rush
                due = self.clock()
            elif wait > 0:
                self._stop.wait(wait)

    def check(self) -> None:
        """Raise the error that stopped the commands, if any."""
        if self.error is not None:
            raise self.error

    # -- what the head follows ---------------------------------------------------------------

    def place(self, times, pyr_deg) -> None:
        """Poses (pitch, yaw, roll degrees) to be shown at these wall-clock times (``clock``'s);
        poses from the first of them on replace those there were."""
        with self._lock:
            self.timeline.add(times, pyr_deg)

    def follow(self, message: dict) -> None:
        """A frame message of a voice-agent integration, as its audio plays (:class:`~.motion.PacedFrames`)."""
        with self._lock:
            self.paced.message(message, self.clock())

    async def send(self, message: dict) -> None:
        """:meth:`follow` as the integrations' ``send=``: ``HeadMotionProcessor(send=head.send)``
        (Pipecat), ``attach_head_motion(session, send=head.send)`` (LiveKit)."""
        self.follow(message)

    def settle(self, seconds: float | None = None) -> float:
        """Ease the head from the last pose sent to :attr:`rest` over ``seconds`` (default
        ``settle_s``), leaving with its own speed; returns when it will be there (``clock``'s time)."""
        from ...live.core import settle_path
        from ...rotations import pitch_yaw_roll_to_rotvec, rotvec_to_pitch_yaw_roll

        now = self.clock()
        n = max(1, int(math.ceil((self.settle_s if seconds is None else float(seconds)) * self.rate_hz)))
        sent = list(self._sent) or [self.limiter.pose if self.limiter is not None else self.rest]
        last, prev = sent[-1], sent[0]
        rv = pitch_yaw_roll_to_rotvec(*np.radians([last, prev, self.rest]).T)
        path = rotvec_to_pitch_yaw_roll(settle_path(rv[0], rv[1], rv[2], n), degrees=True)
        times = now + np.arange(1, n + 1) / self.rate_hz
        with self._lock:
            self.timeline.clear()
            self.timeline.add(times, path)
        return float(times[-1])

    def wait_until(self, t: float, *, poll_s: float = 0.02) -> None:
        """Sleep until ``clock()`` reaches ``t``, raising the commands' error if they stop."""
        while self.clock() < t:
            self.check()
            time.sleep(min(poll_s, max(0.0, t - self.clock())))
        self.check()

    def stop(self, seconds: float | None = None) -> None:
        """Settle to rest (when the commands run) and stop them."""
        if self._thread is not None and self._thread.is_alive() and self.error is None:
            self.wait_until(self.settle(seconds) + 2.0 / self.rate_hz)
        self._halt()

    def _halt(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)

    def close(self) -> None:
        """Stop the commands (where the head is) and, when this object connected, disconnect."""
        self._halt()
        if self._owned:
            try:
                self.robot.__exit__(None, None, None)
            except Exception:  # noqa: BLE001 - a daemon already gone: nothing left to close
                pass

    def __enter__(self) -> ReachyHead:
        try:
            return self.start()
        except BaseException:
            self.close()
            raise

    def __exit__(self, *exc) -> None:
        self.close()


__all__ = ["ReachyHead", "connect", "DEFAULT_RATE_HZ"]
