"""Head motion on a Reachy Mini robot (Pollen Robotics' open-source desktop robot), in-process.

* :mod:`.motion` — the axes, the range and speed limits, the command-rate interpolation and the
  pose record; needs nothing beyond headmotion.
* :mod:`.head` — :class:`ReachyHead`: the robot's head following the motion at the command rate,
  through the ``reachy-mini`` SDK (``pip install "headmotion[reachy]"``).
* :mod:`.audio`, :mod:`.play` — the speech played and the live core's frames put on the head in
  time with it (``headmotion robot reachy``).

``from headmotion.integrations.reachy import ReachyHead`` without the SDK raises
:class:`~headmotion.errors.MissingDependencyError` naming the install line; :mod:`.motion` imports
without it.  docs/robots.md has the recipes and the limits.
"""

from __future__ import annotations

from .motion import HeadLimits, Limiter, PacedFrames, PoseRecord, Timeline, pitch_yaw_roll_of, robot_pose

_SDK = {"ReachyHead": "head", "connect": "head", "DEFAULT_RATE_HZ": "head"}


def __getattr__(name: str):
    if name in _SDK:
        from importlib import import_module

        return getattr(import_module(f".{_SDK[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["HeadLimits", "Limiter", "PacedFrames", "PoseRecord", "Timeline", "pitch_yaw_roll_of", "robot_pose",
           "ReachyHead", "connect", "DEFAULT_RATE_HZ"]
