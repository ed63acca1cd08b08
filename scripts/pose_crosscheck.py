#!/usr/bin/env python
"""Cross-check the video head pose against an independent estimate, per clip and axis (issue 15
item 4).

    python scripts/pose_crosscheck.py [--data DIR] [--cache DIR ...] [--canonical OBJ] [--method kabsch]
                                      [--plots DIR] [--only SUBSTRING]

For every video under ``--data`` (default ../shared/data/talking_video), the FaceMesh landmarks
(read from the first ``--cache`` folder holding them, e.g. the real corpus' cache
~/.cache/headmotion/corpus/talking_video/.cache, which is only read; otherwise tracked and cached
in the last ``--cache`` folder, default /tmp/headmotion-crosscheck) give two pose tracks:

* ours — :func:`headmotion.video.pose.estimate_pose` per shot (what ``corpus from-video`` uses);
* independent — OpenCV ``solvePnP`` (iterative, from EPnP) of the 2D landmarks (x, y only: no
  FaceMesh depth, no per-clip reference) against mediapipe's canonical face geometry
  (``canonical_face_model.obj``, 468 vertices in cm; in head axes: +x the face's left, +y up, +z
  out of the nose), a pinhole camera with focal length = the image diagonal, principal point at
  the centre.  The obj is Apache-2.0 data from google/mediapipe
  (mediapipe/modules/face_geometry/data/canonical_face_model.obj); it is not part of the wheel or
  of this repository: pass its path with ``--canonical`` (default
  ~/.cache/headmotion/canonical_face_model.obj).

Both are expressed relative to their own median pose, low-passed at 8 Hz like the corpus, and
compared per axis (rotation-vector components ≈ pitch, yaw, roll) by Pearson's |r| over the frames
both have.  Prints one row per clip and the median; ``--plots`` writes a PNG per clip.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

DEFAULT_DATA = ROOT.parent / "shared" / "data" / "talking_video"
DEFAULT_CANONICAL = Path.home() / ".cache" / "headmotion" / "canonical_face_model.obj"
VIDEO_EXT = {".mp4", ".mpg", ".mov", ".avi", ".mkv", ".webm"}


def load_canonical(path) -> np.ndarray:
    """The 468 vertices ``(468, 3)`` of mediapipe's canonical face model (head axes, cm)."""
    v = [list(map(float, line.split()[1:4])) for line in Path(path).read_text().splitlines()
         if line.startswith("v ")]
    v = np.array(v[:468])
    if v.shape != (468, 3):
        raise SystemExit(f"{path}: expected 468 vertices, found {len(v)}")
    return v


def pnp_track(points2d: np.ndarray, valid: np.ndarray, model: np.ndarray, *, width: int, height: int,
              focal: float | None = None) -> np.ndarray:
    """Per-frame head rotation (rotvec, head axes, relative to the camera) by solvePnP of the
    canonical model to the 2D landmarks; NaN on invalid frames."""
    import cv2

    from headmotion.video.pose import CAMERA_TO_HEAD

    f = float(focal or np.hypot(width, height))
    K = np.array([[f, 0, width / 2.0], [0, f, height / 2.0], [0, 0, 1.0]])
    obj = np.ascontiguousarray(model * CAMERA_TO_HEAD, dtype=np.float64)  # head → camera axes
    out = np.full((len(points2d), 3), np.nan)
    rvec = tvec = None
    for t in np.flatnonzero(valid):
        p = np.ascontiguousarray(points2d[t], dtype=np.float64)
        if rvec is None:
            ok, rvec, tvec = cv2.solvePnP(obj, p, K, None, flags=cv2.SOLVEPNP_EPNP)
        ok, rvec, tvec = cv2.solvePnP(obj, p, K, None, rvec.copy(), tvec.copy(), True,
                                      flags=cv2.SOLVEPNP_ITERATIVE)
        if not ok:
            rvec = tvec = None
            continue
        Rc = cv2.Rodrigues(rvec)[0]
        Rh = CAMERA_TO_HEAD[:, None] * Rc * CAMERA_TO_HEAD[None, :]
        from scipy.spatial.transform import Rotation

        out[t] = Rotation.from_matrix(Rh).as_rotvec()
    return out


def relative_to_median(rv: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    ok = np.all(np.isfinite(rv), 1)
    out = np.full_like(rv, np.nan)
    if ok.sum() < 2:
        return out
    r = Rotation.from_rotvec(rv[ok])
    med = Rotation.from_rotvec(np.median(rv[ok], 0))
    out[ok] = (r * med.inv()).as_rotvec()
    return out


def smooth(rv: np.ndarray, fps: float, cutoff: float = 8.0) -> np.ndarray:
    """Low-pass each run of finite frames (as the corpus does)."""
    from headmotion.video.quality import find_gaps, lowpass

    out = rv.copy()
    ok = np.all(np.isfinite(rv), 1)
    for a, b in find_gaps(ok):
        if b - a > 30:
            out[a:b] = lowpass(rv[a:b], fps, cutoff)
    return out


def landmarks_for(video: Path, caches: list[Path]):
    """The cached analysis of ``video`` (read-only in all but the last cache folder)."""
    from headmotion.video.build import VideoAnalysis, analyse_cached, cache_key, safe_id

    name = f"{safe_id(video.stem)}-{cache_key(video)}.npz"
    for c in caches:
        f = c / name
        if f.exists():
            try:
                return VideoAnalysis.load(f)
            except Exception:  # noqa: BLE001 - a stale cache: recompute below
                pass
    return analyse_cached(video, caches[-1])[0]


def ours_track(analysis, method: str = "kabsch") -> tuple[np.ndarray, list[int]]:
    """The pipeline's per-frame pose (per shot, relative to each shot's median), before gaps and
    low-pass, and the cuts it found."""
    from headmotion.video import quality as q
    from headmotion.video.pose import RIGID_LANDMARKS, estimate_pose

    lm = analysis.landmarks
    P = lm.points[:, RIGID_LANDMARKS].astype(float)
    det = lm.detected
    cuts = q.detect_cuts(P, det, fps=analysis.fps, image_diff=analysis.image_diff)
    rv = np.full((len(lm), 3), np.nan)
    bounds = [0] + cuts + [len(lm)]
    for a, b in zip(bounds[:-1], bounds[1:]):
        if det[a:b].sum() >= 3:
            rv[a:b] = estimate_pose(P[a:b], det[a:b], method=method, width=lm.width, height=lm.height).rotvec
    return rv, cuts


def crosscheck(video: Path, caches: list[Path], model: np.ndarray, *, method: str = "kabsch",
               focal: float | None = None, focal_ratio: float | None = None, plot_dir: Path | None = None) -> dict:
    from headmotion.video.pose import RIGID_LANDMARKS

    a = landmarks_for(video, caches)
    lm = a.landmarks
    ours, cuts = ours_track(a, method)
    det = lm.detected & np.all(np.isfinite(lm.points[:, :, :2]), axis=(1, 2))
    idx = RIGID_LANDMARKS
    if focal_ratio is not None:
        focal = focal_ratio * lm.width
    raw = pnp_track(lm.points[:, idx, :2].astype(float), det, model[idx], width=lm.width, height=lm.height,
                    focal=focal)
    ind = np.full_like(raw, np.nan)
    bounds = [0] + cuts + [len(lm)]
    for s, e in zip(bounds[:-1], bounds[1:]):
        ind[s:e] = relative_to_median(raw[s:e])
    o, i = smooth(ours, a.fps), smooth(ind, a.fps)
    both = np.all(np.isfinite(o), 1) & np.all(np.isfinite(i), 1)
    r = [abs(float(np.corrcoef(o[both, k], i[both, k])[0, 1])) if both.sum() > 10 else float("nan")
         for k in range(3)]
    sd_o = np.degrees(np.nanstd(o[both], 0))
    sd_i = np.degrees(np.nanstd(i[both], 0))
    if plot_dir is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        t = np.arange(len(o)) / a.fps
        fig, axs = plt.subplots(3, 1, figsize=(10, 6), sharex=True)
        for k, name in enumerate(("pitch", "yaw", "roll")):
            axs[k].plot(t, np.degrees(o[:, k]), lw=1, label="ours")
            axs[k].plot(t, np.degrees(i[:, k]), lw=1, label="PnP canonical")
            axs[k].set_ylabel(f"{name} (deg)  |r|={r[k]:.2f}")
            for c in cuts:
                axs[k].axvline(c / a.fps, color="k", lw=0.5)
        axs[0].legend(fontsize=8)
        axs[0].set_title(video.name)
        axs[-1].set_xlabel("time (s)")
        fig.tight_layout()
        plot_dir.mkdir(parents=True, exist_ok=True)
        fig.savefig(plot_dir / f"{video.parent.name}_{video.stem}.png", dpi=80)
        plt.close(fig)
    return {"clip": f"{video.parent.name}/{video.name}", "frames": int(both.sum()), "cuts": len(cuts),
            "r": r, "sd_ours": sd_o, "sd_pnp": sd_i}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DEFAULT_DATA)
    ap.add_argument("--cache", type=Path, action="append", default=None,
                    help="landmark cache folder(s); the last one is written (default /tmp/headmotion-crosscheck)")
    ap.add_argument("--canonical", type=Path, default=DEFAULT_CANONICAL)
    ap.add_argument("--method", default="kabsch", choices=("kabsch", "pnp"))
    ap.add_argument("--focal", type=float, default=None, help="PnP focal length in pixels (default: image diagonal)")
    ap.add_argument("--focal-ratio", type=float, default=None,
                    help="PnP focal length as a multiple of the image width (instead of --focal)")
    ap.add_argument("--plots", type=Path, default=None)
    ap.add_argument("--only", default=None, help="only clips whose path contains this")
    args = ap.parse_args(argv)
    if not args.canonical.exists():
        print(f"{args.canonical}: not found; download canonical_face_model.obj from google/mediapipe "
              f"(mediapipe/modules/face_geometry/data/) and pass --canonical", file=sys.stderr)
        return 2
    caches = args.cache or [Path.home() / ".cache/headmotion/corpus/talking_video/.cache",
                            Path("/tmp/headmotion-crosscheck")]
    model = load_canonical(args.canonical)
    videos = sorted(p for p in args.data.rglob("*") if p.suffix.lower() in VIDEO_EXT)
    if args.only:
        videos = [v for v in videos if args.only in str(v)]
    print(f"{'clip':48s} {'frames':>6s} {'cuts':>4s}  {'|r| pitch':>9s} {'yaw':>5s} {'roll':>5s}   "
          f"SD ours p/y/r (deg)   SD PnP p/y/r")
    rows = []
    for v in videos:
        try:
            row = crosscheck(v, caches, model, method=args.method, focal=args.focal,
                             focal_ratio=args.focal_ratio, plot_dir=args.plots)
        except Exception as exc:  # noqa: BLE001 - report and go on
            print(f"{v.parent.name}/{v.name}: failed: {exc}")
            continue
        rows.append(row)
        r = row["r"]
        print(f"{row['clip']:48s} {row['frames']:6d} {row['cuts']:4d}  {r[0]:9.3f} {r[1]:5.3f} {r[2]:5.3f}   "
              f"{row['sd_ours'][0]:5.2f} {row['sd_ours'][1]:5.2f} {row['sd_ours'][2]:5.2f}     "
              f"{row['sd_pnp'][0]:5.2f} {row['sd_pnp'][1]:5.2f} {row['sd_pnp'][2]:5.2f}", flush=True)
    if rows:
        R = np.array([r["r"] for r in rows])
        print(f"{'median':48s} {'':6s} {'':4s}  {np.nanmedian(R[:, 0]):9.3f} {np.nanmedian(R[:, 1]):5.3f} "
              f"{np.nanmedian(R[:, 2]):5.3f}")
        print(f"{'minimum':48s} {'':6s} {'':4s}  {np.nanmin(R[:, 0]):9.3f} {np.nanmin(R[:, 1]):5.3f} "
              f"{np.nanmin(R[:, 2]):5.3f}")
        low = [(r["clip"], ["pitch", "yaw", "roll"][k]) for r in rows for k in range(3) if r["r"][k] < 0.85]
        print(f"clips/axes below 0.85: {len(low)} of {3 * len(rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
