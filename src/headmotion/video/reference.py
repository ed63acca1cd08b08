"""The head motion of a style reference (``headmotion synth --style-from REF``): a motion file, or a
talking video whose head pose is estimated from the face (:mod:`.build`, needs the ``video``
extra).  :func:`headmotion.motion.style.style_profile` takes it from there."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import FormatError
from ..types import Motion

#: Extensions read as a talking video by :func:`load_style_reference`; everything else goes to
#: :func:`headmotion.io.load_motion`.
VIDEO_EXTENSIONS = (".mp4", ".mov", ".mkv", ".avi", ".webm", ".mpg", ".mpeg", ".m4v")


def load_style_reference(path, *, audio=None, **options) -> Motion:
    """The head motion of a style reference: a motion file or a talking video.

    Parameters
    ----------
    path : str or Path
        Any file :func:`headmotion.io.load_motion` reads, or a video (extension in
        :data:`VIDEO_EXTENSIONS`); a video's head pose is estimated from the face
        (:mod:`headmotion.video`, needs mediapipe) and the longest usable stretch is returned.
    audio : path, optional
        The video pipeline wants the speech too; a video without an audio track and without a
        same-named .wav is analysed with a silent stand-in (the audio plays no part in the style).
    **options : passed to :func:`headmotion.io.load_motion` (e.g. ``head="Head"`` for BVH)
    """
    p = Path(path)
    if p.suffix.lower() not in VIDEO_EXTENSIONS:
        from ..io.motion import load_motion

        return load_motion(p, **options)
    if not p.is_file():
        raise FormatError("style reference video not found", path=p)
    import tempfile

    from .build import analyse_video, parts_from_analysis
    from .decode import find_sidecar_audio, probe

    with tempfile.TemporaryDirectory(prefix="headmotion-style-") as tmp:
        if audio is None:
            info = probe(p)
            if not info.has_audio and find_sidecar_audio(p) is None:
                import soundfile as sf

                audio = Path(tmp) / "silence.wav"
                dur = max(float(info.duration or 0.0), 1.0) + 1.0
                sf.write(audio, np.zeros(int(dur * 16000), np.float32), 16000)
        analysis = analyse_video(p, audio=audio)
    parts = parts_from_analysis(analysis, rec_id=p.stem)
    best = max(parts, key=lambda part: len(part.motion))
    return best.motion.replace(meta={**best.motion.meta, "source": str(p)})


__all__ = ["load_style_reference", "VIDEO_EXTENSIONS"]
