"""Write the web pages' model files from :func:`headmotion.render.mesh.build_head_mesh` (detail 0):

* ``static/head_mesh.bin`` — the viewer's head (:func:`~headmotion.render.mesh.mesh_to_bytes`);
* ``static/avatar.vrm`` — the avatar page's VRM 1.0 bust (:func:`headmotion.io.vrm.build_vrm`):
  the head, ears, neck and torso of the same model (not the eye and mouth masks), skinned to the
  chest, neck and head bones by the mesh's head weights, plus two eyes (:func:`eyes`: spheres on
  the model's eyeballs, white with a brown iris and a black pupil looking ahead) — the model's own
  eyeballs are skin, made to be masked.

* ``static/talkinghead.glb`` — the TalkingHead page's full-body avatar with the Ready Player Me
  skeleton and blendshapes (:mod:`headmotion.web.talkinghead_avatar`, written by
  :func:`headmotion.io.rpm.rpm_bytes`): the same head, neck, ears and eyes on a body of its own.

Run ``python -m headmotion.web.build_assets`` after changing the mesh or the VRM or glTF writers;
the test suite checks that the committed files match what the code builds.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..io.atomic import atomic_write_bytes
from ..render.mesh import HEAD_CENTER, build_head_mesh, mesh_to_bytes

MESH_FILE = Path(__file__).resolve().parent / "static" / "head_mesh.bin"
AVATAR_FILE = Path(__file__).resolve().parent / "static" / "avatar.vrm"
TALKINGHEAD_FILE = Path(__file__).resolve().parent / "static" / "talkinghead.glb"
WEB_DETAIL = 0
#: the parts of the head model that make the avatar (the masks are for perception tests)
AVATAR_PARTS = ("head", "ears", "neck", "torso")


def build(path=MESH_FILE) -> Path:
    atomic_write_bytes(path, mesh_to_bytes(build_head_mesh(detail=WEB_DETAIL)))
    return Path(path)


#: the eyeballs of :func:`headmotion.render.mesh.head_sdf` (centre about HEAD_CENTER, mirrored in x),
#: 2 mm further forward so that the coarse web mesh (detail 0) does not cover them
EYE_CENTER = (0.031, 0.007, 0.076)
EYE_RADIUS = 0.0125
#: angles from the line of sight (degrees) of the pupil's and the iris's edges
PUPIL_DEG, IRIS_DEG = 11.0, 26.0


def eyes(n_around: int = 24, n_down: int = 16):
    """Two eye spheres: positions, normals, sRGB colours, head weights (1) and triangles."""
    th = np.linspace(0.0, np.pi, n_down)  # from the line of sight (+z) backwards
    ph = np.linspace(-np.pi, np.pi, n_around, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    d = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    ang = np.degrees(T).ravel()
    col = np.where(ang[:, None] < PUPIL_DEG, [0.03, 0.03, 0.03],
                   np.where(ang[:, None] < IRIS_DEG, [0.30, 0.19, 0.11], [0.86, 0.84, 0.80]))
    tris = []
    for i in range(n_down - 1):
        for j in range(n_around):
            a0, b0 = i * n_around + j, i * n_around + (j + 1) % n_around
            tris += [(a0, a0 + n_around, b0), (b0, a0 + n_around, b0 + n_around)]  # outward (e_θ × e_φ)
    idx = np.asarray(tris, np.int64)
    pos, nrm, cols, faces = [], [], [], []
    for k, side in enumerate((1.0, -1.0)):
        c = HEAD_CENTER + np.array(EYE_CENTER) * [side, 1.0, 1.0]
        pos.append(c + EYE_RADIUS * d)
        nrm.append(d)
        cols.append(col)
        faces.append(idx + k * len(d))
    return (np.concatenate(pos).astype(np.float32), np.concatenate(nrm).astype(np.float32),
            np.concatenate(cols).astype(np.float32), np.ones(2 * len(d), np.float32), np.concatenate(faces))


def avatar_bytes() -> bytes:
    """The avatar page's VRM file (module docstring)."""
    from ..io.vrm import vrm_bytes

    m = build_head_mesh(detail=WEB_DETAIL).merged(AVATAR_PARTS)
    e = eyes()
    n = m.n_vertices
    return vrm_bytes(np.concatenate([m.positions, e[0]]), np.concatenate([m.normals, e[1]]),
                     np.concatenate([m.colors, e[2]]), np.concatenate([m.weights, e[3]]),
                     np.concatenate([m.indices.astype(np.int64), e[4] + n]),
                     extras={"made_by": "python -m headmotion.web.build_assets (headmotion.render.mesh at "
                                        "detail 0 and two eye spheres)"})


def build_avatar(path=AVATAR_FILE) -> Path:
    atomic_write_bytes(path, avatar_bytes())
    return Path(path)


def talkinghead_bytes() -> bytes:
    """The TalkingHead page's avatar (module docstring)."""
    from ..io.rpm import rpm_bytes
    from .talkinghead_avatar import avatar_parts

    return rpm_bytes(avatar_parts(eyes(), EYE_CENTER), extras={
        "made_by": "python -m headmotion.web.build_assets (headmotion.render.mesh at detail 0, two eye "
                   "spheres and a body of capsules, on the Ready Player Me skeleton)"})


def build_talkinghead(path=TALKINGHEAD_FILE) -> Path:
    atomic_write_bytes(path, talkinghead_bytes())
    return Path(path)


if __name__ == "__main__":
    print(f"wrote {build()}")
    print(f"wrote {build_avatar()}")
    print(f"wrote {build_talkinghead()}")
