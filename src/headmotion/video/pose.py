"""Head rotation from face landmarks: a rigid fit against the video's own reference shape.

Implements the pose step of "head pose from the face" (docs/spec.md §8) with the rigid-body method the
thesis uses for motion-capture markers (§3.4: rotation by SVD after Söderkvist & Wedin / Kabsch,
expressed relative to a rest pose; paper §4.1 likewise).  Here the "markers" are FaceMesh
landmarks that do not move with speech — nose, nose bridge, forehead, eye corners, cheekbones and
temples; no lips, jaw line, eyelids or eyebrows (:data:`RIGID_LANDMARKS`).

Reference shape.  The canonical face model is not inside the mediapipe wheel and is not copied
from elsewhere.  Instead the reference is built from the clip itself by generalised Procrustes
analysis: every frame's rigid landmarks are centred and scaled to unit RMS size, aligned to the
current reference by Kabsch, and the reference becomes the element-wise median of the aligned
shapes; after three rounds it is rebuilt from the frames nearest the clip's median pose only
(FaceMesh depth is least distorted there), and each landmark of each frame is re-weighted
(Huber) by its residual, so a landmark that does move (a cheek in a smile) counts less.

Two fits are available: ``"kabsch"`` — rigid similarity fit of the 3D landmarks (x, y in pixels,
FaceMesh z on the scale of x); and ``"pnp"`` — OpenCV ``solvePnP`` of the reference shape to the
2D landmarks with a pinhole camera (focal length = image width unless given).  Kabsch is the
default: on the real clips it had the lower frame-to-frame jitter and passed the mirror and
known-rotation tests (see tests/test_video_pose.py); PnP is kept for comparison.

Camera model.  A rigid fit of landmarks measures the face's orientation relative to the ray from
the camera to the face, not to the camera's axis: a head that moves sideways without turning is
seen from a slightly different angle and reads as yaw (up/down: pitch).  With ``width``/``height``
known, each frame's rotation is put back into camera axes, ``R = R_ray R_fit``, where ``R_ray``
turns the optical axis onto the ray through the face centre of a pinhole camera with the principal
point at the image centre and focal length ``focal`` (default: the image diagonal, a ≈ 47°
horizontal field of view at 16:9; a longer lens is the safer guess for crops, as it corrects
less).  FaceMesh's z (a network's guess of relative depth) keeps full weight, and the 122-point
rigid set is used whole; the measurements behind these choices are in
``docs/decisions/video_pose_pipeline.md``.

Axes.  Camera coordinates are x right, y down, z into the scene; the subject faces the camera.
The project's head frame (:mod:`headmotion.rotations`) has +x to the speaker's left (= camera
right), +y up (= camera −y) and +z out of the nose (= towards the camera, camera −z).  Landmarks
are mapped with ``diag(1, −1, −1)`` *before* fitting, so rotations come out directly in our
convention.  The result is expressed relative to the clip's median pose, about axes fixed to the
camera (taken as the torso's, since the speaker faces it): ``R_rel = R_t R_med^T``.  So an in-plane
rotation of the image by φ changes roll by exactly φ, and the result does not depend on the
(arbitrary) orientation of the reference shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ParameterError

# FaceMesh indices that stay put while talking: nose (FACEMESH_NOSE), nose bridge and sides,
# forehead (upper face oval), inner/outer eye corners, cheekbones, temples.
_NOSE = (1, 2, 4, 5, 6, 19, 45, 48, 64, 94, 97, 98, 115, 168, 195, 197, 220, 275, 278, 294, 326,
         327, 344, 440, 3, 248, 51, 281, 236, 456, 198, 420, 131, 360, 122, 351, 188, 412)
_FOREHEAD = (10, 151, 9, 8, 108, 337, 109, 338, 67, 297, 69, 299, 104, 333, 103, 332, 54, 284,
             21, 251, 71, 301, 68, 298)
_EYE_CORNERS = (33, 133, 362, 263)
_CHEEKBONES = (116, 345, 117, 346, 118, 347, 123, 352, 50, 280, 101, 330, 111, 340, 143, 372,
               34, 264, 227, 447, 31, 261)
_TEMPLES = (127, 356, 162, 389, 234, 454)
#: Landmarks used for the rigid fit (sorted FaceMesh indices).
RIGID_LANDMARKS = np.array(sorted(set(_NOSE + _FOREHEAD + _EYE_CORNERS + _CHEEKBONES + _TEMPLES)))

#: Camera axes (x right, y down, z into the scene) → head axes (x speaker's left, y up, z forward).
CAMERA_TO_HEAD = np.array([1.0, -1.0, -1.0])


def batch_kabsch(reference: np.ndarray, points: np.ndarray, weights: np.ndarray | None = None):
    """Similarity fit ``points[t] ≈ s_t R_t reference + c_t`` for many frames at once.

    Parameters
    ----------
    reference : np.ndarray [shape=(N, 3)]
    points : np.ndarray [shape=(T, N, 3)]
    weights : np.ndarray [shape=(N,) or (T, N)], optional

    Returns
    -------
    R : np.ndarray [shape=(T, 3, 3)], proper rotations
    scale : np.ndarray [shape=(T,)]
    center : np.ndarray [shape=(T, 3)]
    """
    a = np.asarray(reference, float)
    b = np.asarray(points, float)
    T, N = b.shape[:2]
    w = np.ones((T, N)) if weights is None else np.broadcast_to(np.asarray(weights, float), (T, N))
    w = w / np.maximum(w.sum(1, keepdims=True), 1e-12)
    ca = np.einsum("tn,ni->ti", w, a)
    cb = np.einsum("tn,tni->ti", w, b)
    A = a[None] - ca[:, None]
    B = b - cb[:, None]
    H = np.einsum("tni,tnj->tij", A * w[..., None], B)
    U, S, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.einsum("tji,tkj->tik", Vt, U)))  # det(V U^T)
    d[d == 0] = 1.0
    D = np.ones((T, 3))
    D[:, 2] = d
    R = np.einsum("tji,tj,tkj->tik", Vt, D, U)  # V diag(D) U^T
    denom = np.einsum("tn,tni,tni->t", w, A, A)
    scale = (S * D).sum(1) / np.maximum(denom, 1e-12)
    center = cb - scale[:, None] * np.einsum("tij,tj->ti", R, ca)
    return R, scale, center


def _normalise(P: np.ndarray):
    """Centre each frame and scale it to unit RMS size: ``(T, N, 3) → (T, N, 3), (T, 3), (T,)``."""
    c = P.mean(1)
    X = P - c[:, None]
    s = np.sqrt((X**2).sum(2).mean(1))
    return X / s[:, None, None], c, s


@dataclass(frozen=True, eq=False)
class PoseFit:
    """Result of :func:`estimate_pose` for one segment.

    Attributes
    ----------
    rotvec : np.ndarray [shape=(T, 3)], radians, head axes, relative to the median pose; NaN where
        the input frame was invalid
    residual : np.ndarray [shape=(T,)], RMS fit residual as a fraction of the face size (NaN invalid)
    scale : np.ndarray [shape=(T,)], face size in pixels (RMS landmark distance from the centre)
    center : np.ndarray [shape=(T, 3)], face centre in pixels (camera axes)
    reference : np.ndarray [shape=(N, 3)], the rigid reference shape (head axes, unit RMS size)
    median_rotation : np.ndarray [shape=(3,)], the median pose relative to the reference (rotvec)
    """

    rotvec: np.ndarray
    residual: np.ndarray
    scale: np.ndarray
    center: np.ndarray
    reference: np.ndarray
    median_rotation: np.ndarray


def build_reference(X: np.ndarray, *, n_iter: int = 3, near_median_deg: float = 4.0,
                    min_fraction: float = 0.2) -> tuple[np.ndarray, np.ndarray]:
    """Rigid reference shape from normalised landmarks ``X (T, N, 3)`` (all frames valid).

    Generalised Procrustes: align to the reference, take the element-wise median, repeat; then
    rebuild from the frames within ``near_median_deg`` of the median pose (at least
    ``min_fraction`` of the frames, the nearest ones).

    Returns
    -------
    reference : np.ndarray [shape=(N, 3)], unit RMS size, centred
    weights : np.ndarray [shape=(N,)], per-landmark weights (inverse residual spread)
    """
    T = len(X)
    med_shape = np.median(X, axis=0)
    k0 = int(np.argmin(((X - med_shape) ** 2).sum((1, 2))))
    ref = X[k0]
    for _ in range(n_iter):
        R, s, c = batch_kabsch(ref, X)
        aligned = np.einsum("tji,tnj->tni", R, (X - c[:, None]) / s[:, None, None])
        ref = np.median(aligned, axis=0)
        ref = ref - ref.mean(0)
        ref /= np.sqrt((ref**2).sum(1).mean())
    R, s, c = batch_kabsch(ref, X)
    rv = Rotation.from_matrix(R).as_rotvec()
    med = np.median(rv, axis=0)
    dist = (Rotation.from_rotvec(med).inv() * Rotation.from_matrix(R)).magnitude()
    n_keep = max(min(T, 3), int(np.ceil(min_fraction * T)), int(np.sum(dist <= np.radians(near_median_deg))))
    keep = np.argsort(dist)[:n_keep]
    aligned = np.einsum("tji,tnj->tni", R[keep], (X[keep] - c[keep, None]) / s[keep, None, None])
    ref = np.median(aligned, axis=0)
    ref = ref - ref.mean(0)
    ref /= np.sqrt((ref**2).sum(1).mean())
    # landmarks that wobble (relative to the rigid fit) get less weight
    spread = np.median(np.linalg.norm(aligned - ref, axis=2), axis=0)
    w = 1.0 / np.maximum(spread, np.median(spread) * 0.5) ** 2
    return ref, w / w.mean()


def _robust_kabsch(ref, X, w_lm, n_iter: int = 2):
    R, s, c = batch_kabsch(ref, X, w_lm)
    for _ in range(n_iter):
        pred = s[:, None, None] * np.einsum("tij,nj->tni", R, ref) + c[:, None]
        r = np.linalg.norm(X - pred, axis=2)  # (T, N)
        k = 2.0 * np.median(r, axis=1, keepdims=True) + 1e-9
        huber = np.where(r <= k, 1.0, k / np.maximum(r, 1e-12))
        R, s, c = batch_kabsch(ref, X, w_lm[None] * huber)
    pred = s[:, None, None] * np.einsum("tij,nj->tni", R, ref) + c[:, None]
    res = np.sqrt(((X - pred) ** 2).sum(2).mean(1)) / np.maximum(s, 1e-12)
    return R, s, c, res


def line_of_sight(center_px: np.ndarray, *, width: int, height: int, focal: float | None = None) -> np.ndarray:
    """Rotations ``(T, 3, 3)`` (head axes) turning the camera's optical axis onto the ray through
    each face centre ``center_px (T, 2)`` (pixels) of a pinhole camera with the principal point at
    the image centre and focal length ``focal`` (default: the image diagonal)."""
    f = float(focal or np.hypot(width, height))
    c = np.asarray(center_px, float)
    d = np.stack([c[:, 0] - width / 2.0, c[:, 1] - height / 2.0, np.full(len(c), f)], 1) * CAMERA_TO_HEAD
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    z = np.array([0.0, 0.0, -1.0])  # the optical axis (camera +z) in head axes
    axis = np.cross(z, d)
    sin = np.linalg.norm(axis, axis=1)
    ang = np.arctan2(sin, d @ z)
    rv = axis * (ang / np.maximum(sin, 1e-12))[:, None]
    rv[sin < 1e-12] = 0.0
    return Rotation.from_rotvec(rv).as_matrix()


def _pnp(ref_h: np.ndarray, pts2d: np.ndarray, scale_px: float, *, width: int, height: int,
         focal: float | None) -> np.ndarray:
    """Rotation (head axes) per frame by ``cv2.solvePnP`` of the reference shape to 2D points."""
    import cv2

    f = float(focal or width)
    K = np.array([[f, 0, width / 2.0], [0, f, height / 2.0], [0, 0, 1.0]])
    obj = (ref_h * CAMERA_TO_HEAD * scale_px).astype(np.float64)  # head → camera axes
    out = np.empty((len(pts2d), 3, 3))
    rvec = tvec = None
    for t, p in enumerate(pts2d):
        p = np.ascontiguousarray(p, dtype=np.float64)
        if rvec is None:
            ok, rvec, tvec = cv2.solvePnP(obj, p, K, None, flags=cv2.SOLVEPNP_EPNP)
            ok, rvec, tvec = cv2.solvePnP(obj, p, K, None, rvec, tvec, True, flags=cv2.SOLVEPNP_ITERATIVE)
        else:
            ok, rvec, tvec = cv2.solvePnP(obj, p, K, None, rvec.copy(), tvec.copy(), True,
                                          flags=cv2.SOLVEPNP_ITERATIVE)
        Rc = cv2.Rodrigues(rvec)[0]
        out[t] = CAMERA_TO_HEAD[:, None] * Rc * CAMERA_TO_HEAD[None, :]  # M Rc M
    return out


def estimate_pose(points: np.ndarray, valid: np.ndarray | None = None, *, method: str = "kabsch",
                  width: int | None = None, height: int | None = None, focal: float | None = None,
                  reference: np.ndarray | None = None, line_of_sight_correction: bool = True) -> PoseFit:
    """Head rotation per frame from FaceMesh landmarks.

    Parameters
    ----------
    points : np.ndarray [shape=(T, 468, 3) or (T, N, 3)]
        Landmarks in pixels, camera axes (x right, y down, z into the scene).  With 468 columns the
        :data:`RIGID_LANDMARKS` subset is taken; otherwise all N points are treated as rigid.
    valid : np.ndarray [shape=(T,), dtype=bool], optional
        Frames to use (default: frames without NaN).
    method : {"kabsch", "pnp"}
    width, height : int, image size in pixels (needed for ``"pnp"``; with ``"kabsch"`` they
        enable the line-of-sight correction)
    focal : float, optional, pinhole focal length in pixels (default: ``width`` for ``"pnp"``, the
        image diagonal for the line-of-sight correction)
    reference : np.ndarray [shape=(N, 3)], optional
        Use this rigid shape (head axes) instead of building one from the clip.
    line_of_sight_correction : bool, put the rotation into camera axes (``"kabsch"``, needs
        ``width`` and ``height``; see the module docstring)

    Returns
    -------
    PoseFit
    """
    P = np.asarray(points, float)
    if P.ndim != 3 or P.shape[2] != 3:
        raise ParameterError(f"landmarks must have shape (T, N, 3); got {P.shape}")
    if P.shape[1] == 468:
        P = P[:, RIGID_LANDMARKS]
    T, N = P.shape[:2]
    finite = np.all(np.isfinite(P), axis=(1, 2))
    valid = finite if valid is None else (np.asarray(valid, bool) & finite)
    if method not in ("kabsch", "pnp"):
        raise ParameterError(f"pose method must be 'kabsch' or 'pnp'; got {method!r}")
    rotvec = np.full((T, 3), np.nan)
    residual = np.full(T, np.nan)
    scale = np.full(T, np.nan)
    center = np.full((T, 3), np.nan)
    if valid.sum() < 1:
        ref = np.zeros((N, 3)) if reference is None else np.asarray(reference, float)
        return PoseFit(rotvec, residual, scale, center, ref, np.zeros(3))
    Ph = P[valid] * CAMERA_TO_HEAD
    X, c, s = _normalise(Ph)
    if reference is None:
        ref, w_lm = build_reference(X)
    else:
        ref = np.asarray(reference, float)
        ref = (ref - ref.mean(0)) / np.sqrt(((ref - ref.mean(0)) ** 2).sum(1).mean())
        w_lm = np.ones(N)
    R, s_fit, c_fit, res = _robust_kabsch(ref, X, w_lm)
    if method == "kabsch" and line_of_sight_correction and width is not None and height is not None:
        R = np.einsum("tij,tjk->tik", line_of_sight(c[:, :2] * CAMERA_TO_HEAD[:2], width=width, height=height,
                                                    focal=focal), R)
    if method == "pnp":
        if width is None or height is None:
            raise ParameterError("pose method 'pnp' needs the image width and height")
        R = _pnp(ref, P[valid][:, :, :2], float(np.median(s)), width=width, height=height, focal=focal)
    rot = Rotation.from_matrix(R)
    med = Rotation.from_rotvec(np.median(rot.as_rotvec(), axis=0))
    rel = (rot * med.inv()).as_rotvec()
    rotvec[valid] = rel
    residual[valid] = res
    scale[valid] = s
    center[valid] = c * CAMERA_TO_HEAD
    return PoseFit(rotvec, residual, scale, center, ref, med.as_rotvec())


def project(reference: np.ndarray, rotvec: np.ndarray, *, scale: float = 100.0,
            center=(256.0, 256.0, 0.0)) -> np.ndarray:
    """Landmarks (camera axes, pixels) of the rigid ``reference`` (head axes) turned by ``rotvec``.

    Scaled-orthographic: x, y in pixels and z a relative depth on the scale of x, as FaceMesh
    reports them.  Used by the known-rotation tests.

    Parameters
    ----------
    reference : np.ndarray [shape=(N, 3)]
    rotvec : np.ndarray [shape=(T, 3)], head axes
    Returns
    -------
    np.ndarray [shape=(T, N, 3)]
    """
    R = Rotation.from_rotvec(np.atleast_2d(rotvec)).as_matrix()
    Ph = scale * np.einsum("tij,nj->tni", R, reference)
    return Ph * CAMERA_TO_HEAD + np.asarray(center, float)


__all__ = ["RIGID_LANDMARKS", "CAMERA_TO_HEAD", "PoseFit", "batch_kabsch",
           "build_reference", "estimate_pose", "line_of_sight", "project"]
