"""Camera cuts within one speaker, on real video, skipped without ../shared.

Two real clips of the same speaker (styletalk: andrew ×2, feifeili ×3) are joined at a known
frame with PyAV (H.264, written to a temporary folder, with the two same-named wavs joined at the
same point); ``corpus from-video``'s pipeline must find the cut within ±1 frame and make the two
parts separate recordings.  A face leaving the frame between the shots (a cut-away without a face,
or the picture sliding out of view) must give a gap and a split, never a traceback."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mediapipe")
av = pytest.importorskip("av")
sf = pytest.importorskip("soundfile")

from headmotion.cli import main  # noqa: E402
from headmotion.corpus import Corpus  # noqa: E402
from headmotion.video.build import analyse_video, parts_from_analysis  # noqa: E402
from headmotion.video.decode import iter_frames  # noqa: E402

pytestmark = [pytest.mark.shared, pytest.mark.slow]
FPS = 30


def _clip(shared_data, stem, start, n):
    d = shared_data / "talking_video" / "styletalk"
    if not (d / f"{stem}.mp4").exists():
        pytest.skip(f"{d / stem}.mp4 absent")
    frames = []
    for i, (_, rgb) in enumerate(iter_frames(d / f"{stem}.mp4", max_side=None)):
        if i >= start + n:
            break
        if i >= start:
            frames.append(rgb)
    a, sr = sf.read(d / f"{stem}.wav")
    assert sr == 16000
    return frames, a[int(start / FPS * sr):int((start + n) / FPS * sr)]


def write_join(path, pieces):
    """Write ``pieces`` — lists of RGB frames and matching 16 kHz audio — one after the other as
    an H.264 mp4 at 30 fps plus a same-named wav; returns the first frame of each piece."""
    starts, frames, audio = [], [], []
    for fr, a in pieces:
        starts.append(len(frames))
        frames += fr
        audio.append(a if len(a) else np.zeros(int(len(fr) / FPS * 16000)))
    with av.open(str(path), "w") as c:
        s = c.add_stream("libx264", rate=FPS)
        s.width, s.height, s.pix_fmt = frames[0].shape[1], frames[0].shape[0], "yuv420p"
        s.options = {"crf": "18"}
        for f in frames:
            for p in s.encode(av.VideoFrame.from_ndarray(np.ascontiguousarray(f), format="rgb24")):
                c.mux(p)
        for p in s.encode():
            c.mux(p)
    sf.write(path.with_suffix(".wav"), np.concatenate(audio), 16000)
    return starts


CASES = {  # (first clip, start frame, n), (second clip, start frame, n)
    "andrew_1_to_2": (("andrew_clip_1", 120, 150), ("andrew_clip_2", 500, 120)),
    "andrew_2_to_1": (("andrew_clip_2", 40, 100), ("andrew_clip_1", 600, 140)),
    "feifeili_1_to_2": (("feifeili_clip1", 30, 120), ("feifeili_clip2_short", 250, 130)),
    "feifeili_2_to_3": (("feifeili_clip2_short", 0, 110), ("feifeili_clip3", 60, 120)),
    "feifeili_3_to_1": (("feifeili_clip3", 100, 100), ("feifeili_clip1", 150, 120)),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_cut_between_two_clips_of_one_speaker(shared_data, tmp_path, case):
    (s1, a1, n1), (s2, a2, n2) = CASES[case]
    video = tmp_path / f"{case}.mp4"
    starts = write_join(video, [_clip(shared_data, s1, a1, n1), _clip(shared_data, s2, a2, n2)])
    cut = starts[1]
    analysis = analyse_video(video)
    parts = parts_from_analysis(analysis, rec_id=case)
    assert len(parts) == 2, [(p.start, p.stop) for p in parts]
    assert abs(parts[0].stop - cut) <= 1 and abs(parts[1].start - cut) <= 1
    assert parts[0].quality["cuts"] == 1
    assert [p.id for p in parts] == [f"{case}_part1", f"{case}_part2"]
    # each part's motion is continuous: no frame-to-frame jump beyond what a head does
    for p in parts:
        step = np.degrees(np.abs(np.diff(p.motion.rotvec, axis=0))).max()
        assert step < 10.0, (p.id, step)


def test_corpus_from_video_splits_at_the_cut(shared_data, tmp_path):
    (s1, a1, n1), (s2, a2, n2) = CASES["andrew_2_to_1"]
    video = tmp_path / "andrew_join.mp4"
    write_join(video, [_clip(shared_data, s1, a1, n1), _clip(shared_data, s2, a2, n2)])
    out = tmp_path / "corpus"
    assert main(["corpus", "from-video", str(video), "-o", str(out), "--speaker", "andrew"]) == 0
    c = Corpus.load(out)
    assert c.ids == ["andrew_join_part1", "andrew_join_part2"]
    assert abs(c[0].duration - n1 / FPS) < 2.5 / FPS and abs(c[1].duration - n2 / FPS) < 2.5 / FPS


@pytest.mark.parametrize("how", ["cutaway", "slide_out"])
def test_face_leaving_the_frame_between_cuts(shared_data, tmp_path, how):
    f1, w1 = _clip(shared_data, "feifeili_clip1", 0, 90)
    f2, w2 = _clip(shared_data, "feifeili_clip3", 0, 90)
    if how == "cutaway":  # 1 s of a picture without a face (the empty wall of the first shot's corner)
        wall = np.broadcast_to(f1[0][:24, :24].mean((0, 1)).astype(np.uint8), f1[0].shape).copy()
        middle = [wall] * 30
    else:  # the picture slides left until the face has left it, then the next shot
        w = f1[-1].shape[1]
        middle = []
        for k in range(1, 16):
            shifted = np.zeros_like(f1[-1])
            dx = int(w * k / 15)
            shifted[:, :w - dx] = f1[-1][:, dx:]
            middle.append(shifted)
    video = tmp_path / f"{how}.mp4"
    starts = write_join(video, [(f1, w1), (middle, np.zeros(int(len(middle) / FPS * 16000))), (f2, w2)])
    parts = parts_from_analysis(analyse_video(video), rec_id=how)
    assert len(parts) == 2
    assert parts[0].stop <= starts[1] + 1 and parts[1].start >= starts[2] - 1
    assert abs(parts[1].start - starts[2]) <= 1
    for p in parts:
        assert np.all(np.isfinite(p.motion.rotvec))
        assert np.degrees(np.abs(np.diff(p.motion.rotvec, axis=0))).max() < 10.0
