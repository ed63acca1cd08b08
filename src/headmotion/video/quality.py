"""Quality control of head pose from video: confidence, gaps, shot cuts, low-pass, summary.

Part of "head pose from the face" (docs/spec.md §8).  The thesis (§3.4) fills short marker dropouts in
motion capture and resets the mean pose per take; for video the equivalents are frames without a
(usable) face, which are marked missing and interpolated when the gap is short, and shot cuts,
where the recording is split because the pose before and after is not the same continuous motion.
Libraries: scipy.signal (Butterworth, zero-phase ``filtfilt``) for the low-pass and scipy's Slerp
for gap filling; shot-cut detectors such as PySceneDetect work on pixel histograms, which a
talking head barely changes between two shots of the same person, so cuts are detected here from
the face itself (jumps and steps of its position, size, shape and pose) and from a one-frame change
of a 32 × 32 grey thumbnail of the picture, measured against the frames around it (PySceneDetect's
thresholds are absolute and would need the same neighbourhood test; not added as a dependency).

Low-pass default.  :data:`DEFAULT_LOWPASS_HZ` = 8 Hz (4th-order Butterworth, zero phase).  Head
motion in speech lies mostly below 5 Hz (the thesis' speed classes split segments at 4.5 and
6.5 Hz, §5.5); above ~8 Hz the pose track from FaceMesh carries mostly landmark noise and the leak
of mouth opening and blinks into pitch.  ``lowpass=None`` (CLI ``--lowpass 0``) switches it off.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import ParameterError

#: Default low-pass cutoff for video head pose (Hz); see the module docstring.
DEFAULT_LOWPASS_HZ = 8.0
#: Gaps (frames without a usable face) up to this long are interpolated; longer ones split.
DEFAULT_MAX_GAP_S = 0.5
#: Parts shorter than this (seconds) are dropped after splitting.
DEFAULT_MIN_PART_S = 1.0
#: Frames whose confidence is below this count as missing.
DEFAULT_MIN_CONFIDENCE = 0.5


def confidence(points: np.ndarray, residual: np.ndarray, *, width: int, height: int,
               n_faces: np.ndarray | None = None) -> np.ndarray:
    """Per-frame confidence in [0, 1] of a face pose.

    The product of (a) the fraction of rigid landmarks inside the image (a face leaving the
    frame loses it; FaceMesh then extrapolates), and (b) a rigid-fit term
    ``exp(-½ (max(0, r − r_med) / (4·MAD))²)``: frames whose landmarks do not fit the clip's
    rigid shape (a wrong face, a badly tracked frame) lose confidence.  Frames without a face
    get 0.

    Parameters
    ----------
    points : np.ndarray [shape=(T, N, 2 or 3)], pixels, NaN where no face
    residual : np.ndarray [shape=(T,)], RMS rigid-fit residual / face size (NaN where no face)
    width, height : int
    n_faces : np.ndarray [shape=(T,)], optional

    Returns
    -------
    np.ndarray [shape=(T,)]
    """
    P = np.asarray(points, float)
    T = len(P)
    conf = np.zeros(T)
    ok = np.all(np.isfinite(P[..., :2]), axis=(1, 2)) & np.isfinite(residual)
    if n_faces is not None:
        ok &= np.asarray(n_faces) > 0
    if not ok.any():
        return conf
    x, y = P[ok, :, 0], P[ok, :, 1]
    inside = ((x >= 0) & (x < width) & (y >= 0) & (y < height)).mean(1)
    r = residual[ok]
    med = np.median(r)
    mad = np.median(np.abs(r - med)) * 1.4826 + 1e-4
    fit = np.exp(-0.5 * (np.maximum(0.0, r - med) / (4.0 * mad)) ** 2)
    in_term = np.clip((inside - 0.8) / 0.2, 0.0, 1.0)  # all inside → 1, ≤ 80 % inside → 0
    conf[ok] = in_term * fit
    return conf


#: Largest head rotation speed taken as real motion between two frames (deg/s); more is a cut.
MAX_TURN_DEG_S = 300.0


def detect_cuts(points: np.ndarray, valid: np.ndarray, *, fps: float | None = None, rel_jump: float = 0.25,
                scale_jump: float = 0.15, shape_jump: float = 0.06, factor: float = 8.0,
                max_turn_deg_s: float = MAX_TURN_DEG_S, window: int = 5, step_threshold: float = 10.4,
                spike_ratio: float = 3.9, image_diff: np.ndarray | None = None,
                image_ratio: float = 2.7) -> list[int]:
    """Frames where a new shot starts (a sudden jump of the face or of the picture).

    Four tests, any of which marks a cut (two shots of the same person may
    barely change the picture or barely move the face, so both are watched):

    1. **Jump of one measure.**  Between each valid frame and the previous one: the shift of the
       face centre relative to the face size, the relative change of face size, and the change of
       face *shape* after removing position, size and rotation (Procrustes distance of the
       normalised rigid landmarks; a different person or view gives a large one).  A cut when a
       measure exceeds both its absolute threshold and ``factor`` times the clip's median.
    2. **Turn faster than a head turns.**  The rotation between the two frames' landmark sets
       (Procrustes fit) above ``max_turn_deg_s / fps`` degrees (300 °/s: 10° in one frame at
       30 fps; fast conversational head turns on the real clips peaked near 275 °/s).  Needs
       ``fps``.
    3. **A step, not a motion.**  The face's state — centre (in face sizes), log size and the
       orientation chained from the frame-to-frame rotations — each divided by its typical
       frame-to-frame change (1.4826 × MAD), is compared as the median of ``window`` frames before
       against the median of ``window`` frames after: a cut when that step exceeds
       ``step_threshold`` *and* the jump into the frame (state plus shape change) is more than
       ``spike_ratio`` times every other jump in the window (the frame right after is left out,
       as the tracker needs a frame to settle).  A fast but continuous head movement spreads over
       several frames and fails the second condition; a one-frame tracking glitch comes back and
       fails the first.
    4. **A one-frame change of the picture** (needs ``image_diff``, the mean absolute difference
       of consecutive 32 × 32 grey thumbnails, :func:`thumbnail`): a cut where it exceeds
       ``image_ratio`` times every other difference within ``window`` frames (plus half a grey
       level).  Camera motion, a moving head and compression change the picture over several
       frames; a cut changes it at once.  On the real clips no frame of a single shot reached 2.3;
       the joined clips' cuts reached 3.0–22.

    Cuts within two frames of each other count once (the first).  Measured on real joins of two
    clips of one speaker (tests/test_video_cuts_real.py): each cut found at its frame; in the 59
    real clips only the split the earlier detector already made (pc_avs Audio_Source_741400104,
    frame 108: a 12° turn in one frame at 25 fps, where the picture does not change at once, so
    possibly a very fast turn rather than a cut).  The margins are narrow on the fastest-moving
    speaker (andrew), so a cut that changes neither the picture, the framing nor the pose can be
    missed.

    Parameters
    ----------
    points : np.ndarray [shape=(T, N, 3)], rigid landmarks in pixels, NaN where no face
    valid : np.ndarray [shape=(T,), dtype=bool]
    fps : float, optional, frame rate (enables test 2)
    rel_jump, scale_jump, shape_jump, factor : test 1
    max_turn_deg_s : float, test 2
    window, step_threshold, spike_ratio : test 3
    image_diff : np.ndarray [shape=(T,)], optional, picture change into each frame (test 4)
    image_ratio : float, test 4

    Returns
    -------
    list of int, frame indices (each is the first frame of a new shot), ascending
    """
    P = np.asarray(points, float)
    v = np.asarray(valid, bool) & np.all(np.isfinite(P), axis=(1, 2))
    idx = np.flatnonzero(v)
    image_cuts = [] if image_diff is None else _picture_cuts(np.asarray(image_diff, float), window, image_ratio)
    if len(idx) < 2:
        return image_cuts
    Q = P[idx]
    c = Q.mean(1)
    X = Q - c[:, None]
    s = np.sqrt((X**2).sum(2).mean(1))
    Xn = X / s[:, None, None]
    # Procrustes distance between consecutive frames (fit previous → next)
    Rb, sb, cb = _pairwise_fit(Xn[:-1], Xn[1:])
    pred = sb[:, None, None] * np.einsum("tij,tnj->tni", Rb, Xn[:-1]) + cb[:, None]
    d_shape = np.sqrt(((Xn[1:] - pred) ** 2).sum(2).mean(1))
    d_pos = np.linalg.norm(c[1:, :2] - c[:-1, :2], axis=1) / np.minimum(s[1:], s[:-1])
    d_scale = np.abs(np.log(s[1:] / s[:-1]))
    cut = np.zeros(len(idx) - 1, bool)
    for d, thr in ((d_pos, rel_jump), (d_scale, scale_jump), (d_shape, shape_jump)):
        cut |= (d > thr) & (d > factor * (np.median(d) + 1e-9))
    turn = Rotation.from_matrix(Rb).magnitude()
    if fps is not None and fps > 0:
        cut |= np.degrees(turn) > max_turn_deg_s / fps
    cut |= _steps(c, s, Rb, d_shape, window=window, step_threshold=step_threshold, spike_ratio=spike_ratio)
    # a face cut at valid frame k+1 happened somewhere after valid frame k: where the picture
    # changed, if it did in between, else at the face's return
    found = sorted(set(int(idx[k + 1]) for k in np.flatnonzero(cut)) | set(image_cuts))
    out: list[int] = []
    for f in found:
        if out and f - out[-1] <= 2:
            continue
        out.append(f)
    return out


def _picture_cuts(d: np.ndarray, window: int, ratio: float) -> list[int]:
    """Test 4 of :func:`detect_cuts`: frames whose picture change ``d[k]`` (into frame k) stands
    out of its neighbourhood."""
    out = []
    n = len(d)
    for k in range(1, n):
        around = np.r_[max(1, k - window):k, k + 1:min(n, k + 1 + window)]
        if len(around) and np.isfinite(d[k]) and d[k] > ratio * (np.nanmax(d[around]) + 0.5):
            out.append(k)
    return out


def thumbnail(rgb: np.ndarray, size: int = 32) -> np.ndarray:
    """A ``size × size`` grey thumbnail (box-averaged, float32 0–255) of an RGB frame, for the
    picture-change test of :func:`detect_cuts`."""
    from PIL import Image

    return np.asarray(Image.fromarray(np.ascontiguousarray(rgb)).convert("L").resize((size, size), Image.BOX),
                      dtype=np.float32)


def _steps(c, s, Rb, d_shape, *, window: int, step_threshold: float, spike_ratio: float) -> np.ndarray:
    """Test 3 of :func:`detect_cuts` on valid frames; ``cut[k]`` is the jump from frame k to k+1."""
    n = len(c)
    cut = np.zeros(max(n - 1, 0), bool)
    if n < 2 * window + 2:
        return cut
    O = np.empty((n, 3, 3))
    O[0] = np.eye(3)
    for k in range(1, n):
        O[k] = Rb[k - 1] @ O[k - 1]
    ori = Rotation.from_matrix(O).as_rotvec()
    F = np.column_stack([c[:, :2] / np.median(s), np.log(s), ori])
    dF = np.diff(F, axis=0)
    sig = 1.4826 * np.median(np.abs(dF - np.median(dF, 0)), 0) + 1e-9
    sig_sh = 1.4826 * np.median(np.abs(d_shape - np.median(d_shape))) + 1e-9
    J = np.sqrt(((dF / sig) ** 2).sum(1) + np.clip((d_shape - np.median(d_shape)) / sig_sh, 0, None) ** 2)
    Fn = F / sig
    for k in range(1, n):  # a new shot starting at valid frame k
        before, after = Fn[max(0, k - window):k], Fn[k:k + window]
        if len(before) < 2 or len(after) < 2:
            continue
        step = np.linalg.norm(np.median(after, 0) - np.median(before, 0))
        if step <= step_threshold:
            continue
        around = np.r_[max(0, k - 1 - window):k - 1, k + 1:min(n - 1, k + window)]
        if J[k - 1] > spike_ratio * (J[around].max() if len(around) else 0.0):
            cut[k - 1] = True
    return cut


def _pairwise_fit(A: np.ndarray, B: np.ndarray):
    """Similarity fit ``B[t] ≈ s R A[t] + c`` for each t (``A, B (T, N, 3)``)."""
    ca, cb = A.mean(1), B.mean(1)
    A0, B0 = A - ca[:, None], B - cb[:, None]
    H = np.einsum("tni,tnj->tij", A0, B0)
    U, S, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.einsum("tji,tkj->tik", Vt, U)))
    d[d == 0] = 1.0
    D = np.ones((len(A), 3))
    D[:, 2] = d
    R = np.einsum("tji,tj,tkj->tik", Vt, D, U)
    s = (S * D).sum(1) / np.maximum((A0**2).sum((1, 2)), 1e-12)
    c = cb - s[:, None] * np.einsum("tij,tj->ti", R, ca)
    return R, s, c


def find_gaps(missing: np.ndarray) -> list[tuple[int, int]]:
    """Runs of True in ``missing (T,)`` as ``[(start, stop), ...]`` (stop exclusive)."""
    m = np.concatenate([[False], np.asarray(missing, bool), [False]])
    d = np.diff(m.astype(np.int8))
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist()))


def fill_gaps(rotvec: np.ndarray, times: np.ndarray | None = None, *, max_gap: int) -> tuple[np.ndarray, list]:
    """Interpolate interior runs of NaN rows no longer than ``max_gap`` frames (spherical).

    Parameters
    ----------
    rotvec : np.ndarray [shape=(T, 3)], NaN rows are missing
    times : np.ndarray [shape=(T,)], optional frame times (default: frame index)
    max_gap : int

    Returns
    -------
    filled : np.ndarray [shape=(T, 3)], still NaN in gaps that were too long or at the ends
    gaps : list of (start, stop, filled: bool)
    """
    from scipy.spatial.transform import Slerp

    r = np.array(rotvec, float, copy=True)
    T = len(r)
    t = np.arange(T, dtype=float) if times is None else np.asarray(times, float)
    missing = ~np.all(np.isfinite(r), axis=1)
    gaps = []
    for a, b in find_gaps(missing):
        ok = b - a <= max_gap and a > 0 and b < T
        if ok:
            sl = Slerp([t[a - 1], t[b]], Rotation.from_rotvec(r[[a - 1, b]]))
            r[a:b] = sl(t[a:b]).as_rotvec()
        gaps.append((a, b, ok))
    return r, gaps


def split_segments(usable: np.ndarray, cuts: list[int], *, min_len: int = 1) -> list[tuple[int, int]]:
    """Contiguous runs of usable frames, also split at ``cuts``; runs shorter than ``min_len`` dropped."""
    u = np.asarray(usable, bool).copy()
    bounds = []
    for a, b in find_gaps(u):
        start = a
        for c in cuts:
            if a < c < b:
                bounds.append((start, c))
                start = c
        bounds.append((start, b))
    return [(a, b) for a, b in bounds if b - a >= max(1, min_len)]


def lowpass(rotvec: np.ndarray, fps: float, cutoff: float | None = DEFAULT_LOWPASS_HZ, *, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass of a rotation-vector track ``(T, 3)`` (no-op when ``cutoff``
    is None/0 or not below the Nyquist rate, or the track is too short to filter)."""
    r = np.asarray(rotvec, float)
    if not cutoff:
        return r
    if cutoff < 0:
        raise ParameterError(f"low-pass cutoff must be positive (or 0 = off); got {cutoff}")
    nyq = fps / 2.0
    if cutoff >= nyq * 0.99:
        return r
    from scipy.signal import butter, sosfiltfilt

    sos = butter(order, cutoff / nyq, output="sos")
    padlen = min(len(r) - 1, 3 * (2 * len(sos) + 1))
    if len(r) < 4 or padlen < 1:
        return r
    return sosfiltfilt(sos, r, axis=0, padlen=padlen)


def jitter_deg(rotvec: np.ndarray) -> np.ndarray:
    """Median absolute frame-to-frame change per axis, degrees ``(3,)``."""
    r = np.asarray(rotvec, float)
    if len(r) < 2:
        return np.zeros(3)
    return np.degrees(np.nanmedian(np.abs(np.diff(r, axis=0)), axis=0))


QUALITY_COLUMNS = ("recording", "speaker", "source", "seconds", "fps", "detection", "confidence", "two_faces", "gaps",
                   "gaps_filled", "cuts", "sd_pitch", "sd_yaw", "sd_roll",
                   "jitter_pitch", "jitter_yaw", "jitter_roll", "note")


def format_quality_table(rows: list[dict]):
    """A rich Table of quality rows (see :data:`QUALITY_COLUMNS`)."""
    from rich.table import Table

    t = Table(title="video → head pose quality (SD and jitter in degrees)")
    heads = {"recording": "recording", "seconds": "s", "detection": "detect", "confidence": "conf",
             "two_faces": "2 faces",
             "gaps": "gaps", "gaps_filled": "filled", "cuts": "cuts", "sd_pitch": "SD p",
             "sd_yaw": "SD y", "sd_roll": "SD r", "jitter_pitch": "jit p", "jitter_yaw": "jit y",
             "jitter_roll": "jit r", "note": "note"}
    for h in heads.values():
        t.add_column(h, justify="left" if h in ("recording", "note") else "right")
    for r in rows:
        cells = []
        for k in heads:
            v = r.get(k, "")
            if isinstance(v, float):
                v = f"{v:.0%}" if k in ("detection", "two_faces", "confidence") else f"{v:.2f}" if k.startswith(("sd", "jit")) else f"{v:.1f}"
            cells.append(str(v))
        t.add_row(*cells)
    return t


__all__ = ["DEFAULT_LOWPASS_HZ", "DEFAULT_MAX_GAP_S", "DEFAULT_MIN_PART_S", "DEFAULT_MIN_CONFIDENCE",
           "confidence", "detect_cuts", "thumbnail", "MAX_TURN_DEG_S", "find_gaps", "fill_gaps",
           "split_segments", "lowpass", "jitter_deg", "QUALITY_COLUMNS", "format_quality_table"]
