"""Head motion from ordinary talking video (docs/spec.md §8: "train on your own data, from mocap or from
an ordinary talking video (head pose estimated from the face)").

* :mod:`.decode` — frames with timestamps and the audio track (PyAV).
* :mod:`.landmarks` — mediapipe FaceMesh landmarks (optional extra ``headmotion[video]``).
* :mod:`.pose` — rigid reference shape from the clip's own landmarks, rotation per frame.
* :mod:`.quality` — confidence, gaps, shot cuts, low-pass, quality summary.
* :mod:`.build` — a corpus directory from videos (``headmotion corpus from-video``).

Nothing heavy is imported here; mediapipe is imported only when tracking starts.
"""

from __future__ import annotations

__all__ = ["decode", "landmarks", "pose", "quality", "build"]
