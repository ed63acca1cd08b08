"""Reading and writing audio and motion files (the I/O edge of docs/design.md's data flow).

* :func:`load_audio` / :func:`save_audio` — :mod:`headmotion.io.audio` (soundfile, PyAV, soxr).
* :func:`load_motion` / :func:`save_motion` — :mod:`headmotion.io.motion`, which dispatches on the
  extension (and, for ``.csv``, on the header) to the BVH, OptiTrack Motive, C3D, OpenFace, Live
  Link Face, SMPL/SMPL-H/SMPL-X ``.npz`` (:mod:`headmotion.io.smpl`) and native CSV/JSON/NPZ
  modules.
"""

from .audio import load_audio, save_audio
from .motion import load_motion, motion_info, save_motion

__all__ = ["load_audio", "save_audio", "load_motion", "save_motion", "motion_info"]
