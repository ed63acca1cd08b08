"""Face landmarks per video frame with mediapipe FaceMesh (the tracking step of the video → pose
path; docs/spec.md §8 "head pose estimated from the face").

Library: mediapipe 0.10.14's legacy ``solutions.face_mesh`` (468 landmarks, x and y normalised
by the image width and height, z a relative depth on the scale of x).  It is pinned because it is
the last release whose wheel ships the face-landmark model, so nothing is downloaded at run time;
the newer Tasks API needs a separate ``.task`` model file.  Considered and not used: dlib's
68-point predictor (model file download, no depth) and OpenFace (a C++ binary).  mediapipe is an
optional extra (``pip install headmotion[video]``) and is imported only when tracking starts.

Output coordinates are converted to pixels of the original frame (``x·W, y·H, z·W``), i.e. the
camera frame: x right, y down, z into the scene.  :mod:`headmotion.video.pose` maps them to the
project's axis convention.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np

from ..errors import MissingDependencyError

N_LANDMARKS = 468


def _import_mediapipe():
    try:
        import mediapipe as mp  # noqa: F401
        from mediapipe.python.solutions import face_mesh  # noqa: F401
    except ImportError as exc:
        raise MissingDependencyError(
            "building a corpus from video needs mediapipe (face landmarks): "
            f"pip install headmotion[video]  (import failed: {exc})"
        ) from None
    return face_mesh


@dataclass(frozen=True, eq=False)
class LandmarkTrack:
    """Face landmarks of one video.

    Attributes
    ----------
    times : np.ndarray [shape=(T,)], frame presentation times in seconds (container clock)
    points : np.ndarray [shape=(T, 468, 3), dtype=float32]
        Pixel coordinates of the original frame, camera axes (x right, y down, z into the scene);
        NaN on frames without a face.
    n_faces : np.ndarray [shape=(T,), dtype=int8], faces found in each frame (0, 1 or 2 = "two or more")
    width, height : int, original frame size in pixels
    """

    times: np.ndarray
    points: np.ndarray
    n_faces: np.ndarray
    width: int
    height: int

    def __len__(self) -> int:
        return len(self.times)

    @property
    def detected(self) -> np.ndarray:
        """``(T,)`` bool: a face was found."""
        return self.n_faces > 0

    def to_arrays(self) -> dict:
        return {"times": self.times, "points": self.points, "n_faces": self.n_faces,
                "size": np.array([self.width, self.height])}

    @classmethod
    def from_arrays(cls, d) -> "LandmarkTrack":
        w, h = (int(v) for v in d["size"])
        return cls(np.asarray(d["times"], float), np.asarray(d["points"], np.float32),
                   np.asarray(d["n_faces"], np.int8), w, h)


class FaceMeshTracker:
    """A FaceMesh instance in video (tracking) mode; use as a context manager.

    Parameters
    ----------
    max_faces : int
        Faces searched for per frame (2 lets us notice a second face and keep the tracked one).
    min_detection_confidence, min_tracking_confidence : float
        mediapipe's thresholds; below them a frame counts as "no face".
    """

    def __init__(self, *, max_faces: int = 2, min_detection_confidence: float = 0.5,
                 min_tracking_confidence: float = 0.5):
        self.max_faces = max_faces
        self.min_detection_confidence = min_detection_confidence
        self.min_tracking_confidence = min_tracking_confidence
        self._mesh = None
        self._prev_center: np.ndarray | None = None

    def __enter__(self) -> "FaceMeshTracker":
        face_mesh = _import_mediapipe()
        self._mesh = face_mesh.FaceMesh(
            static_image_mode=False, max_num_faces=self.max_faces, refine_landmarks=False,
            min_detection_confidence=self.min_detection_confidence,
            min_tracking_confidence=self.min_tracking_confidence)
        return self

    def __exit__(self, *exc) -> None:
        if self._mesh is not None:
            self._mesh.close()
            self._mesh = None

    def process(self, rgb: np.ndarray) -> tuple[np.ndarray | None, int]:
        """Landmarks of the tracked face in one RGB frame.

        Returns
        -------
        points : np.ndarray [shape=(468, 3)] normalised (x/W, y/H, z/W), or None without a face
        n_faces : int
        """
        if self._mesh is None:
            raise RuntimeError("use FaceMeshTracker as a context manager")
        res = self._mesh.process(rgb)
        faces = res.multi_face_landmarks or []
        if not faces:
            return None, 0
        arrs = [np.array([(p.x, p.y, p.z) for p in f.landmark], dtype=np.float32) for f in faces]
        if len(arrs) == 1:
            chosen = arrs[0]
        else:  # keep the face nearest the previous one, else the largest
            centers = [a[:, :2].mean(0) for a in arrs]
            if self._prev_center is not None:
                k = int(np.argmin([np.linalg.norm(c - self._prev_center) for c in centers]))
            else:
                k = int(np.argmax([np.ptp(a[:, 0]) * np.ptp(a[:, 1]) for a in arrs]))
            chosen = arrs[k]
        self._prev_center = chosen[:, :2].mean(0)
        return chosen, len(arrs)


def track_landmarks(frames: Iterable[tuple[float, np.ndarray]], *, width: int, height: int,
                    progress: Callable[[int], None] | None = None, **tracker_options) -> LandmarkTrack:
    """Run FaceMesh over ``(time_s, rgb)`` frames (e.g. from :func:`~headmotion.video.decode.iter_frames`).

    Parameters
    ----------
    frames : iterable of (float, np.ndarray [shape=(h, w, 3), dtype=uint8])
    width, height : int
        Size of the *original* frames; landmarks are returned in these pixel units even when the
        frames were scaled down for speed.
    progress : callable(n_done), optional
    """
    times: list[float] = []
    pts: list[np.ndarray] = []
    nf: list[int] = []
    nan = np.full((N_LANDMARKS, 3), np.nan, np.float32)
    scale = np.array([width, height, width], np.float32)
    with FaceMeshTracker(**tracker_options) as tracker:
        for i, (t, rgb) in enumerate(frames):
            p, n = tracker.process(rgb)
            times.append(t)
            pts.append(nan if p is None else p * scale)
            nf.append(min(n, 2))
            if progress is not None:
                progress(i + 1)
    points = np.stack(pts) if pts else np.zeros((0, N_LANDMARKS, 3), np.float32)
    return LandmarkTrack(np.asarray(times, float), points, np.asarray(nf, np.int8), int(width), int(height))


__all__ = ["LandmarkTrack", "FaceMeshTracker", "track_landmarks", "N_LANDMARKS"]
