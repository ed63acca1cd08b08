"""Regenerate the example motion files in this folder (our own, synthetic).

1 s nod (pitch), 1 s shake (yaw), 1 s tilt (roll) at 30 fps: 2 Hz sinusoids under a half-sine
envelope, 15 degrees peak.  Run: ``python examples/motion/make_examples.py``.
"""

from pathlib import Path

import numpy as np

from headmotion.io import save_motion
from headmotion.types import Motion

HERE = Path(__file__).resolve().parent
fps = 30.0
t = np.arange(int(3 * fps)) / fps
rv = np.zeros((len(t), 3))
for k in range(3):
    seg = (t >= k) & (t < k + 1)
    u = t[seg] - k
    rv[seg, k] = np.radians(15) * np.sin(2 * np.pi * 2 * u) * np.sin(np.pi * u)
m = Motion(rv, fps, meta={"description": "generated: 1 s nod (pitch), 1 s shake (yaw), 1 s tilt (roll), "
                                          "15 deg peak, 2 Hz",
                          "generator": "headmotion examples/motion (sinusoids)"})
for ext in ("bvh", "npz", "csv"):
    save_motion(m, HERE / f"nod_shake_tilt.{ext}")
print(m)
