"""The project's own head model, built procedurally (thesis §4.2.3 animation styles).

The thesis rendered its stimuli with the Poser heads; we cannot ship those, so the head here is
built from scratch: a signed-distance description of a human head (cranium, forehead, brow ridge,
cheekbones, jaw, chin, nose, lips, shallow eye sockets) blended with smooth minima, turned into a
triangle mesh by casting rays from the centre of the head (the head is star-shaped about that
point), plus a hair cap (a thickness added above a hairline), two ears (dished ellipsoids with a
rim), a neck and a static bust.  The black boxes over the eyes and the mouth that the thesis used
(so that eye and lip motion do not leak into judgements of head motion) are thin shells that follow
the face, built by casting rays from the front.

Everything is in the head frame of :mod:`headmotion.rotations` (metres; +x speaker's left, +y up,
+z forward out of the nose), with the rotation pivot — roughly the top of the neck — at the origin.
Every vertex carries a skinning weight: 1 on the head, 0 on the bust, blended along the neck, so the
renderer can rotate the head relative to a torso that stays put.

Libraries considered: scikit-image's ``marching_cubes`` would polygonise the same distance field
but adds a dependency for one call and gives an irregular mesh; trimesh/pyvista primitives would
not give a face.  Ray casting a star-shaped field with numpy gives a regular latitude/longitude
grid (clean normals, a seam hidden at the back of the head) in well under a second.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

#: Centre of the skull in the head frame (metres); rays are cast from here.
HEAD_CENTER = np.array([0.0, 0.085, 0.01])

#: Material ids stored per vertex (the renderer colours by style and material).
SKIN, HAIR, CLOTH, MASK, EAR = 0, 1, 2, 3, 4

# colours (sRGB, 0..1) of the textured style
_SKIN_RGB = np.array([0.86, 0.66, 0.55])
_BLUSH_RGB = np.array([0.84, 0.55, 0.48])
_BROW_RGB = np.array([0.24, 0.16, 0.11])
_HAIR_RGB = np.array([0.23, 0.15, 0.10])
_CLOTH_RGB = np.array([0.20, 0.27, 0.38])


@dataclass(frozen=True)
class MeshPart:
    """One drawable part of the head model.

    Attributes
    ----------
    name : str
    positions : np.ndarray [shape=(N, 3), dtype=float32], metres, head frame
    normals : np.ndarray [shape=(N, 3), dtype=float32], unit length
    colors : np.ndarray [shape=(N, 3), dtype=float32], sRGB in [0, 1] (textured style)
    materials : np.ndarray [shape=(N,), dtype=float32], one of SKIN, HAIR, CLOTH, MASK, EAR
    weights : np.ndarray [shape=(N,), dtype=float32], 1 = moves with the head, 0 = torso
    indices : np.ndarray [shape=(M, 3), dtype=uint32], counter-clockwise seen from outside
    """

    name: str
    positions: np.ndarray
    normals: np.ndarray
    colors: np.ndarray
    materials: np.ndarray
    weights: np.ndarray
    indices: np.ndarray

    @property
    def n_vertices(self) -> int:
        return len(self.positions)

    @property
    def n_triangles(self) -> int:
        return len(self.indices)

    def interleaved(self) -> np.ndarray:
        """``(N, 11)`` float32: position, normal, colour, material, weight (the GPU layout)."""
        return np.hstack(
            [self.positions, self.normals, self.colors, self.materials[:, None], self.weights[:, None]]
        ).astype(np.float32)


@dataclass(frozen=True)
class HeadMesh:
    """The whole model: parts ``head``, ``ears``, ``neck``, ``torso`` and ``mask``."""

    parts: tuple[MeshPart, ...]

    def part(self, name: str) -> MeshPart:
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(name)

    def merged(self, names) -> MeshPart:
        """One part made of the named parts (indices re-based)."""
        sel = [self.part(n) for n in names]
        offs = np.cumsum([0] + [p.n_vertices for p in sel[:-1]])
        cat = lambda attr: np.concatenate([getattr(p, attr) for p in sel])  # noqa: E731
        idx = np.concatenate([p.indices + np.uint32(o) for p, o in zip(sel, offs)])
        return MeshPart("+".join(names), cat("positions"), cat("normals"), cat("colors"),
                        cat("materials"), cat("weights"), idx.astype(np.uint32))

    @property
    def n_triangles(self) -> int:
        return sum(p.n_triangles for p in self.parts)


# ---------------------------------------------------------------------------------------------
# signed distance field of the head (relative to HEAD_CENTER)
# ---------------------------------------------------------------------------------------------
def _ellipsoid(p, c, r):
    """Approximate signed distance to an axis-aligned ellipsoid (Quilez's bound)."""
    q = (p - np.asarray(c)) / np.asarray(r)
    k0 = np.sqrt(np.einsum("...i,...i->...", q, q))
    q1 = q / np.asarray(r)
    k1 = np.sqrt(np.einsum("...i,...i->...", q1, q1))
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


def _round_cone(p, a, b, r1, r2):
    """Signed distance to a cone between spheres (a, r1) and (b, r2) (a tapered capsule)."""
    a = np.asarray(a, float)
    b = np.asarray(b, float)
    ba = b - a
    l2 = ba @ ba
    rr = r1 - r2
    a2 = l2 - rr * rr
    il2 = 1.0 / l2
    pa = p - a
    y = pa @ ba
    z = y - l2
    xv = pa * l2 - y[..., None] * ba
    x2 = np.sum(xv * xv, axis=-1)
    y2 = y * y * l2
    z2 = z * z * l2
    k = np.sign(rr) * rr * rr * x2
    out = (np.sqrt(x2 * a2 * il2) + y * rr) * il2 - r1
    m1 = np.sign(z) * a2 * z2 > k
    m2 = np.sign(y) * a2 * y2 < k
    out = np.where(m1, np.sqrt(x2 + z2) * il2 - r2, out)
    out = np.where(~m1 & m2, np.sqrt(x2 + y2) * il2 - r1, out)
    return out


def _smin(a, b, k):
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b * (1 - h) + a * h - k * h * (1 - h)


def _smax(a, b, k):
    return -_smin(-a, -b, k)


def head_sdf(p: np.ndarray) -> np.ndarray:
    """Signed distance (metres, approximate) to the bare head surface (no hair, ears, neck).

    Parameters
    ----------
    p : np.ndarray [shape=(..., 3)], points relative to :data:`HEAD_CENTER`

    Returns
    -------
    np.ndarray [shape=(...)], negative inside
    """
    p = np.asarray(p, float)
    mx = p * np.array([-1.0, 1.0, 1.0])  # mirror for paired features
    px = np.abs(p[..., 0:1])
    sym = np.concatenate([px, p[..., 1:]], axis=-1)  # |x|: paired features on both sides
    del mx

    d = _ellipsoid(p, (0, 0.015, -0.010), (0.074, 0.082, 0.094))          # cranium
    d = _smin(d, _ellipsoid(p, (0, 0.022, 0.028), (0.064, 0.062, 0.066)), 0.02)   # forehead
    # mid-face and jaw: narrower towards the chin
    y = p[..., 1]
    taper = np.clip(1.0 + 2.0 * np.minimum(y + 0.02, 0.0), 0.75, 1.0)
    pf = np.stack([p[..., 0] / taper, y, p[..., 2]], axis=-1)
    d = _smin(d, _ellipsoid(pf, (0, -0.036, 0.022), (0.066, 0.068, 0.064)), 0.02)
    d = _smin(d, _ellipsoid(p, (0, -0.083, 0.032), (0.050, 0.024, 0.046)), 0.02)     # mandible
    d = _smin(d, _ellipsoid(p, (0, -0.094, 0.056), (0.025, 0.018, 0.020)), 0.02)     # chin
    d = _smin(d, _ellipsoid(sym, (0.052, -0.066, 0.000), (0.014, 0.024, 0.034)), 0.025)  # jaw angle
    d = _smin(d, _ellipsoid(sym, (0.044, -0.006, 0.058), (0.020, 0.016, 0.022)), 0.012)  # cheekbone
    d = _smin(d, _ellipsoid(p, (0, 0.029, 0.074), (0.050, 0.012, 0.017)), 0.012)    # brow ridge
    d = _smax(d, -_ellipsoid(sym, (0.031, 0.008, 0.090), (0.016, 0.010, 0.011)), 0.008)  # sockets
    d = _smin(d, _ellipsoid(sym, (0.031, 0.007, 0.074), (0.012, 0.011, 0.012)), 0.004)  # eyeballs
    nose = _round_cone(p, (0, 0.020, 0.084), (0, -0.024, 0.112), 0.0065, 0.0105)
    nose = _smin(nose, _ellipsoid(p, (0, -0.029, 0.097), (0.017, 0.009, 0.011)), 0.006)  # wings
    d = _smin(d, nose, 0.006)
    d = _smin(d, _ellipsoid(p, (0, -0.049, 0.087), (0.024, 0.0075, 0.011)), 0.006)  # upper lip
    d = _smin(d, _ellipsoid(p, (0, -0.062, 0.084), (0.021, 0.0085, 0.011)), 0.006)  # lower lip
    return d


def _cast(origin: np.ndarray, dirs: np.ndarray, r_max: float, n_coarse: int = 48) -> np.ndarray:
    """Distance along each ray from ``origin`` to the outermost surface crossing, ``(N,)``."""
    ts = np.linspace(r_max, 0.0, n_coarse)
    pts = origin + dirs[:, None, :] * ts[None, :, None]           # (N, S, 3)
    inside = head_sdf(pts) <= 0
    first = np.argmax(inside, axis=1)                              # first sample inside, from outside
    hit = inside[np.arange(len(dirs)), first]
    lo = ts[first]                                                 # inside
    hi = ts[np.maximum(first - 1, 0)]                              # outside
    for _ in range(16):
        mid = 0.5 * (lo + hi)
        inn = head_sdf(origin + dirs * mid[:, None]) <= 0
        lo = np.where(inn, mid, lo)
        hi = np.where(inn, hi, mid)
    return np.where(hit, 0.5 * (lo + hi), 0.0)


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def _vertex_normals(pos: np.ndarray, idx: np.ndarray) -> np.ndarray:
    a, b, c = pos[idx[:, 0]], pos[idx[:, 1]], pos[idx[:, 2]]
    fn = np.cross(b - a, c - a)                                    # area weighted
    n = np.zeros_like(pos)
    for k in range(3):
        np.add.at(n, idx[:, k], fn)
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return n / np.maximum(ln, 1e-12)


def _sphere_grid(n_lon: int, n_lat: int):
    """Unit directions on a latitude/longitude grid with the seam at -z (the back).

    Returns directions ``(N, 3)``, the triangle indices ``(M, 3)`` (outward CCW) and per-vertex
    (polar angle, azimuth)."""
    theta = np.linspace(0, np.pi, n_lat + 1)[1:-1]                 # rings, pole excluded
    phi = np.linspace(-np.pi, np.pi, n_lon, endpoint=False)       # azimuth from +z, towards +x
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    dirs = np.stack([np.sin(th) * np.sin(ph), np.cos(th), np.sin(th) * np.cos(ph)], -1).reshape(-1, 3)
    angles = np.stack([th.ravel(), ph.ravel()], -1)
    top = len(dirs)
    bottom = top + 1
    dirs = np.vstack([dirs, [[0, 1, 0], [0, -1, 0]]])
    angles = np.vstack([angles, [[0, 0], [np.pi, 0]]])
    rings = n_lat - 1
    tris = []
    v = lambda i, j: i * n_lon + (j % n_lon)  # noqa: E731
    for j in range(n_lon):
        tris.append((top, v(0, j + 1), v(0, j)))
        tris.append((bottom, v(rings - 1, j), v(rings - 1, j + 1)))
    for i in range(rings - 1):
        for j in range(n_lon):
            a, b, c, d = v(i, j), v(i, j + 1), v(i + 1, j), v(i + 1, j + 1)
            tris.append((a, b, d))
            tris.append((a, d, c))
    idx = np.asarray(tris, dtype=np.int64)
    # make winding outward: check against the direction
    p = dirs
    n = np.cross(p[idx[:, 1]] - p[idx[:, 0]], p[idx[:, 2]] - p[idx[:, 0]])
    flip = np.sum(n * p[idx].mean(axis=1), axis=1) < 0
    idx[flip] = idx[flip][:, [0, 2, 1]]
    return dirs, idx, angles


def _hairline(azimuth: np.ndarray) -> np.ndarray:
    """Height (relative to the head centre) above which hair grows, by azimuth (0 = front)."""
    a = np.abs(azimuth)
    return np.interp(a, [0, 0.30 * np.pi, 0.42 * np.pi, 0.50 * np.pi, 0.60 * np.pi, 0.78 * np.pi, np.pi],
                     [0.070, 0.062, 0.045, 0.030, 0.012, -0.048, -0.058])


def _build_head(n_lon: int, n_lat: int) -> MeshPart:
    dirs, idx, ang = _sphere_grid(n_lon, n_lat)
    r = _cast(np.zeros(3), dirs, 0.16)
    pos = dirs * r[:, None]
    # hair: a cap of thickness up to 9 mm above the hairline, thinning over 1.5 cm of height
    az = np.arctan2(pos[:, 0], pos[:, 2])
    s = pos[:, 1] - _hairline(az)
    hair = _smoothstep(0.0, 0.008, s)
    bare_normals = _vertex_normals(pos, idx)
    pos = pos + bare_normals * ((0.008 + 0.004 * _smoothstep(0.05, 0.09, pos[:, 1])) * hair)[:, None]
    nrm = _vertex_normals(pos, idx)

    col = np.tile(_SKIN_RGB, (len(pos), 1))
    # warmer cheeks, nose and lips
    blush = np.exp(-(((np.abs(pos[:, 0]) - 0.040) / 0.018) ** 2 + ((pos[:, 1] + 0.022) / 0.018) ** 2)) * (pos[:, 2] > 0.03)
    blush = np.maximum(blush, np.exp(-((pos[:, 0] / 0.014) ** 2 + ((pos[:, 1] + 0.018) / 0.02) ** 2)) * (pos[:, 2] > 0.09))
    lips = np.exp(-((pos[:, 0] / 0.022) ** 4 + ((pos[:, 1] + 0.055) / 0.011) ** 4)) * (pos[:, 2] > 0.07)
    col = col + (0.55 * blush)[:, None] * (_BLUSH_RGB - _SKIN_RGB)
    col = col + lips[:, None] * (np.array([0.72, 0.40, 0.38]) - col)
    # eyebrows: arcs above the eye sockets
    bx = np.abs(pos[:, 0])
    brow_y = 0.030 + 0.004 * np.sin(np.clip((bx - 0.012) / 0.04, 0, 1) * np.pi) - 0.006 * np.clip((bx - 0.04) / 0.015, 0, 1)
    brow = (_smoothstep(0.0052, 0.0030, np.abs(pos[:, 1] - brow_y)) * _smoothstep(0.008, 0.014, bx)
            * _smoothstep(0.056, 0.050, bx) * (pos[:, 2] > 0.05))
    col = col + brow[:, None] * (_BROW_RGB - col)
    col = col + hair[:, None] * (_HAIR_RGB - col)
    mat = np.where(hair > 0.5, HAIR, SKIN).astype(np.float32)
    return MeshPart("head", (pos + HEAD_CENTER).astype(np.float32), nrm.astype(np.float32),
                    col.astype(np.float32), mat, np.ones(len(pos), np.float32),
                    idx.astype(np.uint32))


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _build_ears(n: int = 28) -> MeshPart:
    dirs, idx, _ = _sphere_grid(n, n // 2 + 2)
    # local frame: x = outward thickness, y = up, z = forward; a dish with a thick rim
    rho2 = dirs[:, 1] ** 2 + dirs[:, 2] ** 2
    out = np.where(dirs[:, 0] > 0, 0.0035 + 0.0065 * rho2 ** 2, 0.0045)
    local = np.stack([dirs[:, 0] * out, dirs[:, 1] * 0.031, dirs[:, 2] * 0.019], -1)
    # ear lobe: a little fuller at the bottom
    local[:, 2] += 0.003 * np.clip(-dirs[:, 1], 0, 1) ** 2
    parts_pos, parts_idx = [], []
    for side in (+1, -1):
        rot = _rot("y", side * np.radians(-22)) @ _rot("x", np.radians(-12))  # flare back, lean back
        p = local @ rot.T
        p = p * np.array([side, 1, 1])
        centre = HEAD_CENTER + np.array([side * 0.0745, -0.004, -0.014])
        p = p + centre
        i = idx if side > 0 else idx[:, [0, 2, 1]]  # mirroring flips the winding
        parts_idx.append(i + len(parts_pos) * len(dirs))
        parts_pos.append(p)
    pos = np.vstack(parts_pos)
    idx2 = np.vstack(parts_idx)
    nrm = _vertex_normals(pos, idx2)
    col = np.tile(_SKIN_RGB + 0.35 * (_BLUSH_RGB - _SKIN_RGB), (len(pos), 1))
    return MeshPart("ears", pos.astype(np.float32), nrm.astype(np.float32), col.astype(np.float32),
                    np.full(len(pos), EAR, np.float32), np.ones(len(pos), np.float32),
                    idx2.astype(np.uint32))


def _build_neck(n_around: int = 36, n_along: int = 16) -> MeshPart:
    ys = np.linspace(0.035, -0.17, n_along)
    a = np.linspace(-np.pi, np.pi, n_around, endpoint=False)
    Y, A = np.meshgrid(ys, a, indexing="ij")
    flare = 1.0 + 0.5 * _smoothstep(-0.07, -0.15, Y)              # widens into the trapezius
    rx = 0.060 * flare
    rz = 0.057 * (1.0 + 0.1 * _smoothstep(-0.07, -0.15, Y))
    cz = -0.012 + 0.10 * np.minimum(Y, 0.0) * -0.1                 # leans slightly forward
    pos = np.stack([rx * np.sin(A), Y, cz + rz * np.cos(A)], -1).reshape(-1, 3)
    tris = []
    for i in range(n_along - 1):
        for j in range(n_around):
            a0, b0 = i * n_around + j, i * n_around + (j + 1) % n_around
            a1, b1 = a0 + n_around, b0 + n_around
            tris += [(a0, a1, b0), (b0, a1, b1)]
    idx = np.asarray(tris, np.int64)
    n = np.cross(pos[idx[:, 1]] - pos[idx[:, 0]], pos[idx[:, 2]] - pos[idx[:, 0]])
    outward = pos[idx].mean(1) - np.array([0, 1, 0]) * pos[idx].mean(1)[:, 1:2]
    flip = np.sum(n * outward, 1) < 0
    idx[flip] = idx[flip][:, [0, 2, 1]]
    nrm = _vertex_normals(pos, idx)
    w = _smoothstep(-0.11, 0.0, pos[:, 1])
    col = np.tile(_SKIN_RGB * 0.97, (len(pos), 1))
    return MeshPart("neck", pos.astype(np.float32), nrm.astype(np.float32), col.astype(np.float32),
                    np.full(len(pos), SKIN, np.float32), w.astype(np.float32), idx.astype(np.uint32))


def _build_torso(n_lon: int = 48, n_lat: int = 24) -> MeshPart:
    dirs, idx, _ = _sphere_grid(n_lon, n_lat)
    # a superellipsoid: square-ish shoulders
    e = 0.55
    s = np.sign(dirs) * np.abs(dirs) ** e
    pos = s * np.array([0.215, 0.13, 0.11]) + np.array([0.0, -0.25, -0.02])
    # slope the shoulders down and away from the neck
    pos[:, 1] -= 0.06 * (np.abs(pos[:, 0]) / 0.215) ** 2 * (dirs[:, 1] > -0.2)
    nrm = _vertex_normals(pos, idx)
    col = np.tile(_CLOTH_RGB, (len(pos), 1))
    mat = np.full(len(pos), CLOTH, np.float32)
    return MeshPart("torso", pos.astype(np.float32), nrm.astype(np.float32), col.astype(np.float32),
                    mat, np.zeros(len(pos), np.float32), idx.astype(np.uint32))


def _front_surface_z(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """z of the face surface seen from the front at (x, y) (relative to the head centre)."""
    origin = np.stack([x, y, np.full_like(x, 0.16)], -1)
    ts = np.linspace(0.0, 0.16, 80)
    pts = origin[:, None, :] - np.array([0, 0, 1.0]) * ts[None, :, None]
    inside = head_sdf(pts) <= 0
    first = np.argmax(inside, axis=1)
    lo = ts[np.maximum(first - 1, 0)]  # outside
    hi = ts[first]                     # inside
    for _ in range(22):
        mid = 0.5 * (lo + hi)
        inn = head_sdf(origin - np.array([0, 0, 1.0]) * mid[:, None]) <= 0
        hi = np.where(inn, mid, hi)
        lo = np.where(inn, lo, mid)
    return 0.16 - 0.5 * (lo + hi)


#: The black boxes (thesis §4.2.3): (x half-width, y bottom, y top) relative to the head centre.
MASK_BOXES = {"eyes": (0.053, -0.008, 0.0235), "mouth": (0.033, -0.076, -0.038)}


def _build_mask(res: int = 28, offset: float = 0.0035) -> MeshPart:
    pos_all, idx_all = [], []
    for hw, y0, y1 in MASK_BOXES.values():
        nx, ny = res, max(4, int(res * (y1 - y0) / (2 * hw)) + 4)
        xs = np.linspace(-hw, hw, nx)
        ys = np.linspace(y0, y1, ny)
        X, Y = np.meshgrid(xs, ys, indexing="ij")
        Z = _front_surface_z(X.ravel(), Y.ravel()).reshape(X.shape)
        # smooth the shell (it should read as a box, not follow every wrinkle)
        from scipy.ndimage import uniform_filter

        Z = np.maximum(uniform_filter(Z, size=5, mode="nearest"), Z) + offset
        p = np.stack([X, Y, Z], -1).reshape(-1, 3)
        tris = []
        for i in range(nx - 1):
            for j in range(ny - 1):
                a, b = i * ny + j, (i + 1) * ny + j
                tris += [(a, b, b + 1), (a, b + 1, a + 1)]
        idx = np.asarray(tris, np.int64)
        n = np.cross(p[idx[:, 1]] - p[idx[:, 0]], p[idx[:, 2]] - p[idx[:, 0]])
        flip = n[:, 2] < 0
        idx[flip] = idx[flip][:, [0, 2, 1]]
        idx_all.append(idx + sum(len(q) for q in pos_all))
        pos_all.append(p)
    pos = np.vstack(pos_all) + HEAD_CENTER
    idx = np.vstack(idx_all)
    nrm = _vertex_normals(pos, idx)
    n = len(pos)
    return MeshPart("mask", pos.astype(np.float32), nrm.astype(np.float32), np.zeros((n, 3), np.float32),
                    np.full(n, MASK, np.float32), np.ones(n, np.float32), idx.astype(np.uint32))


@functools.lru_cache(maxsize=4)
def build_head_mesh(*, detail: int = 1) -> HeadMesh:
    """Build the head model (cached per ``detail``).

    Parameters
    ----------
    detail : int, 0 (coarse, for the browser), 1 (default, ~26k triangles) or 2 (fine)

    Returns
    -------
    HeadMesh with parts ``head``, ``ears``, ``neck``, ``torso``, ``mask``
    """
    n_lon, n_lat = {0: (96, 64), 1: (128, 84), 2: (192, 128)}.get(int(detail), (128, 84))
    return HeadMesh((
        _build_head(n_lon, n_lat),
        _build_ears(),
        _build_neck(),
        _build_torso(),
        _build_mask(),
    ))


def mesh_to_bytes(mesh: HeadMesh) -> bytes:
    """Serialise the model for the browser viewer (``static/head_mesh.bin``).

    Layout (little endian): magic ``b"HMSH"``, uint32 version (1), uint32 number of parts; then per
    part: uint32 name length, the UTF-8 name, uint32 N vertices, uint32 M triangles, N×11 float32
    (position, normal, colour, material, weight), M×3 uint32 indices (padded to 4 bytes)."""
    import struct

    out = [b"HMSH", struct.pack("<II", 1, len(mesh.parts))]
    for p in mesh.parts:
        name = p.name.encode()
        pad = (-len(name)) % 4
        out.append(struct.pack("<I", len(name)) + name + b"\0" * pad)
        out.append(struct.pack("<II", p.n_vertices, p.n_triangles))
        out.append(p.interleaved().astype("<f4").tobytes())
        out.append(p.indices.astype("<u4").tobytes())
    return b"".join(out)


def mesh_from_bytes(data: bytes) -> HeadMesh:
    """Inverse of :func:`mesh_to_bytes`."""
    import struct

    if data[:4] != b"HMSH":
        from ..errors import FormatError

        raise FormatError("not a headmotion mesh file (expected magic b'HMSH')")
    _, n_parts = struct.unpack_from("<II", data, 4)
    off = 12
    parts = []
    for _ in range(n_parts):
        (ln,) = struct.unpack_from("<I", data, off)
        off += 4
        name = data[off:off + ln].decode()
        off += ln + (-ln) % 4
        nv, nt = struct.unpack_from("<II", data, off)
        off += 8
        v = np.frombuffer(data, "<f4", nv * 11, off).reshape(nv, 11)
        off += nv * 44
        i = np.frombuffer(data, "<u4", nt * 3, off).reshape(nt, 3)
        off += nt * 12
        parts.append(MeshPart(name, v[:, 0:3], v[:, 3:6], v[:, 6:9], v[:, 9], v[:, 10], i))
    return HeadMesh(tuple(parts))


__all__ = ["HeadMesh", "MeshPart", "build_head_mesh", "head_sdf", "mesh_to_bytes", "mesh_from_bytes",
           "HEAD_CENTER", "MASK_BOXES", "SKIN", "HAIR", "CLOTH", "MASK", "EAR"]
