"""The live frame record and the JSON-lines output (the format of ``headmotion
stream``).  Seeds: silent (a transport format).

One record per motion frame: ``{"frame": i, "time": i / fps, "rotvec": [rx, ry, rz],
"pitch_yaw_roll_deg": [p, y, r]}`` — rotation vector in radians in the package's convention
(:mod:`headmotion.rotations`), Euler angles in degrees from
:func:`~headmotion.rotations.rotvec_to_pitch_yaw_roll`.  The same dicts go to every output
(JSON lines, WebSocket, VMC), so what a client receives can be compared line for line.
"""

from __future__ import annotations

import json

import numpy as np

from ..rotations import rotvec_to_pitch_yaw_roll


def frame_records(rotvec: np.ndarray, fps: float, first: int) -> list[dict]:
    """Records for the rows of ``rotvec (n, 3)``, numbered from ``first``."""
    rv = np.asarray(rotvec, dtype=np.float64).reshape(-1, 3)
    if len(rv) == 0:
        return []
    pyr = rotvec_to_pitch_yaw_roll(rv, degrees=True)
    return [{"frame": first + k, "time": round((first + k) / fps, 4),
             "rotvec": [round(float(v), 6) for v in r],
             "pitch_yaw_roll_deg": [round(float(v), 4) for v in a]}
            for k, (r, a) in enumerate(zip(rv, pyr))]


class JsonLinesOutput:
    """Writes one JSON object per line to a text stream and flushes after each batch."""

    name = "json lines"

    def __init__(self, stream):
        self.stream = stream

    def send(self, records: list[dict]) -> None:
        if records:
            self.stream.write("".join(json.dumps(r) + "\n" for r in records))
            self.stream.flush()

    def close(self) -> None:
        try:
            self.stream.flush()
        except (OSError, ValueError):
            pass


__all__ = ["frame_records", "JsonLinesOutput"]
