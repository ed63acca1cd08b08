"""How much of the head's rotation the neck carries, measured on skeletal mocap.

The seeds are silent on it (the thesis models the head relative to the torso as one rotation,
§2.2.3).  A BVH export with the whole rotation on the Head joint makes rigs bend at one joint;
:func:`headmotion.io.bvh.save_bvh` therefore spreads it over Neck and Head with a share ``s``
(neck ``exp(s·r)``, head the rest).  The default share is what real mocap shows, measured here.

Estimator.  In a skeleton torso → neck joints (e.g. ``Neck``, ``Neck1``) → ``Head``, let ``T(t)``
be the head's rotation relative to the torso (all chain joints composed) and ``N(t)`` the neck
joints' composition (the chain without the head).  Both are taken about their own mean rotation
(``dT = mean(T)⁻¹ T`` as a rotation vector, likewise ``dN``), so the static bend of the rest pose
does not count, only the motion.  The share is the least-squares slope of ``dN`` on ``dT`` over all
frames and the three axes, ``s = Σ dN·dT / Σ dT·dT``: the fraction of the head's movement the neck
chain makes.  The slope is also reported per axis and per quarter of the take (its spread).

On the ZEGGS take in ``../shared/data/mocap_speech/zeggs`` (2065 frames, 30 fps; chain Spine3 →
Neck → Neck1 → Head) it is **0.93** (quarters 0.92–0.96; per axis pitch 1.00, yaw 0.89, roll 1.09;
Neck alone 0.52, Neck1 alone 0.38, the Head joint itself 0.03): the neck makes nearly all the
movement and the head rides on it.  One take of one (retargeted) actor: a measured default, not a
law; ``save_bvh(neck_share=...)`` sets another.

Libraries considered: none measures this; the rotation maths is scipy's.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ParameterError


def _dev(rot: Rotation) -> np.ndarray:
    return (rot.mean().inv() * rot).as_rotvec()


def _slope(a: np.ndarray, b: np.ndarray) -> float:
    den = float((b * b).sum())
    return float((a * b).sum() / den) if den > 0 else float("nan")


def measure_neck_share(path, *, head: str | None = None, relative_to: str | None = None,
                       n_parts: int = 4) -> dict:
    """The share of the head's motion carried by the neck joints of a BVH take.

    Parameters
    ----------
    path : BVH file
    head, relative_to : joint names, as in :func:`headmotion.io.bvh.load_bvh` (found by name
        when omitted)
    n_parts : int, the take is also measured in this many equal parts (spread of the estimate)

    Returns
    -------
    dict: ``share`` (all axes), ``per_axis`` (3,), ``parts`` (n_parts,), ``joints`` (name → the
    slope of that joint alone), ``chain`` (joint names), ``frames``, ``fps``.

    Raises
    ------
    ParameterError when the chain from the torso joint to the head has no neck joint.
    """
    from ..io.bvh import find_head, find_torso, read_bvh_file

    bvh = read_bvh_file(path)
    h = find_head(bvh, head)
    ref = find_torso(bvh, h, relative_to)
    if ref is None:
        raise ParameterError(f"{path}: measure_neck_share needs a torso joint, not relative_to='world'")
    chain = bvh.chain(ref, h)
    if len(chain) < 2:
        raise ParameterError(f"{path}: no neck joint between {bvh.joints[ref].name!r} and "
                             f"{bvh.joints[h].name!r}")
    local = [bvh.local_rotations(j) for j in chain]
    neck = local[0]
    for r in local[1:-1]:
        neck = neck * r
    total = neck * local[-1]
    dn, dt = _dev(neck), _dev(total)
    n = len(dt)
    bounds = np.linspace(0, n, n_parts + 1).astype(int)
    parts = [_slope(_dev(neck[a:b]), _dev(total[a:b])) for a, b in zip(bounds[:-1], bounds[1:])]
    return {
        "share": _slope(dn, dt),
        "per_axis": [_slope(dn[:, k], dt[:, k]) for k in range(3)],
        "parts": parts,
        "joints": {bvh.joints[j].name: _slope(_dev(r), dt) for j, r in zip(chain, local)},
        "chain": [bvh.joints[j].name for j in chain],
        "frames": n, "fps": bvh.fps,
    }


__all__ = ["measure_neck_share"]
