"""Seeing head motion: an offscreen 3D head (thesis §4.2.3 animation styles) and preview videos.

* :func:`render_video` — motion(s) + speech → H.264 MP4 (grid of several motions with labels).
* :class:`HeadRenderer` / :func:`render_pose` — frames as numpy images (moderngl on EGL).
* :func:`plot_motion` — pitch/yaw/roll over time in degrees (matplotlib), speech underneath.
* :func:`build_head_mesh` — the project's own procedurally built head.

moderngl and matplotlib are imported only when these are called.
"""

from __future__ import annotations

STYLES = ("textured", "smooth", "silhouette")


def render_video(motions, out, **kwargs):
    """See :func:`headmotion.render.video.render_video`."""
    from .video import render_video as _rv

    return _rv(motions, out, **kwargs)


def render_pose(rotvec=(0.0, 0.0, 0.0), **kwargs):
    """See :func:`headmotion.render.offscreen.render_pose`."""
    from .offscreen import render_pose as _rp

    return _rp(rotvec, **kwargs)


def plot_motion(motions, out=None, **kwargs):
    """See :func:`headmotion.render.plot.plot_motion`."""
    from .plot import plot_motion as _pm

    return _pm(motions, out, **kwargs)


def __getattr__(name):
    if name == "HeadRenderer":
        from .offscreen import HeadRenderer

        return HeadRenderer
    if name == "build_head_mesh":
        from .mesh import build_head_mesh

        return build_head_mesh
    raise AttributeError(name)


__all__ = ["render_video", "render_pose", "plot_motion", "HeadRenderer", "build_head_mesh", "STYLES"]
