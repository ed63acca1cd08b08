"""Video → head pose on real clips from ../shared/data/talking_video (skipped when absent).

Validation: mirror test, known rotations (synthetic projection of the fitted shape,
and real frames warped in-plane), audio/video sync, stability, bad inputs, the CLI.  Only a few
seconds of a few clips are tracked; results are cached for the session.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.errors import FormatError

pytestmark = pytest.mark.shared

mediapipe = pytest.importorskip("mediapipe")

FRENCH = "dfrf/french.mp4"
N_FRENCH = 240  # 8 s at 30 fps


@pytest.fixture(scope="session")
def tv(shared_data):
    d = shared_data / "talking_video"
    if not d.is_dir():
        pytest.skip(f"{d} is absent")
    return d


@pytest.fixture(scope="session")
def french(tv):
    from headmotion.video.build import analyse_video

    return analyse_video(tv / FRENCH, max_frames=N_FRENCH)


@pytest.fixture(scope="session")
def french_flipped(tv):
    from headmotion.video.build import analyse_video

    return analyse_video(tv / FRENCH, max_frames=N_FRENCH, transform=lambda im: im[:, ::-1])


@pytest.fixture(scope="session")
def french_frames(tv):
    from headmotion.video.decode import iter_frames

    out = []
    for i, (t, im) in enumerate(iter_frames(tv / FRENCH)):
        if i >= 60:
            break
        out.append((t, im))
    return out


@pytest.fixture(scope="session")
def grid_analyses(tv):
    from headmotion.video.build import analyse_video

    return [analyse_video(p) for p in sorted((tv / "grid").glob("*.mpg"))]


def _one_part(analysis, **kw):
    from headmotion.video.build import parts_from_analysis

    parts = parts_from_analysis(analysis, rec_id="x", **kw)
    assert len(parts) == 1
    return parts[0]


def test_real_clip_decodes_with_timestamps_and_synced_audio(french):
    lm = french.landmarks
    assert len(lm) == N_FRENCH and french.fps == pytest.approx(30.0)
    assert lm.times[0] == pytest.approx(0.08)  # this clip's video starts 80 ms after its audio
    assert np.allclose(np.diff(lm.times), 1 / 30, atol=1e-4)
    assert lm.detected.mean() > 0.98
    assert french.audio.sample_rate == 16000
    assert french.audio.duration == pytest.approx(N_FRENCH / 30, abs=0.05)


def test_mirror_negates_yaw_and_roll_keeps_pitch(french, french_flipped):
    a = _one_part(french).motion.rotvec
    b = _one_part(french_flipped).motion.rotvec
    n = min(len(a), len(b))
    corr = [np.corrcoef(a[:n, k], b[:n, k])[0, 1] for k in range(3)]
    assert corr[0] >= 0.8, corr
    assert corr[1] <= -0.8, corr
    assert corr[2] <= -0.8, corr


def test_known_rotations_of_the_fitted_real_shape(french, rng):
    from headmotion.video.pose import RIGID_LANDMARKS, estimate_pose, project

    lm = french.landmarks
    fit = estimate_pose(lm.points[:, RIGID_LANDMARKS], lm.detected)
    ref = fit.reference
    scale = float(np.nanmedian(fit.scale))
    true = np.radians(rng.uniform(-15, 15, (200, 3)))
    pts = project(ref, true, scale=scale, center=(256, 256, 0))
    pts += rng.normal(0, 1.0, pts.shape)  # 1 px noise
    est = estimate_pose(pts).rotvec
    e, t = Rotation.from_rotvec(est), Rotation.from_rotvec(true)
    err = np.degrees(((e * e[0].inv()) * (t * t[0].inv()).inv()).magnitude())
    assert np.median(err) < 1.0


@pytest.mark.parametrize("angle", [8.0, -5.0])
def test_in_plane_rotation_of_real_frames_is_recovered_as_roll(french_frames, angle):
    """Frames k and N+k are the same image, the second warped by ``angle`` degrees
    counter-clockwise (top of the head towards image left = the speaker's right): roll must
    change by +angle (within 1°), pitch and yaw not at all."""
    import cv2

    from headmotion.video.landmarks import track_landmarks
    from headmotion.video.pose import RIGID_LANDMARKS, estimate_pose

    h, w = french_frames[0][1].shape[:2]
    M = cv2.getRotationMatrix2D((w / 2, h / 2), angle, 1.0)
    warped = [(t + 10.0, cv2.warpAffine(im, M, (w, h), flags=cv2.INTER_LINEAR)) for t, im in french_frames]
    lm = track_landmarks(french_frames + warped, width=w, height=h)
    fit = estimate_pose(lm.points[:, RIGID_LANDMARKS], lm.detected)
    n = len(french_frames)
    r = Rotation.from_rotvec(fit.rotvec)
    change = np.degrees((r[n:] * r[:n].inv()).as_rotvec())
    med = np.median(change, axis=0)
    assert med[2] == pytest.approx(angle, abs=1.0)
    assert abs(med[0]) < 1.0 and abs(med[1]) < 1.0


def test_stability_jitter_below_0_6_degrees(french):
    from headmotion.video.quality import jitter_deg

    part = _one_part(french)
    jit = jitter_deg(part.motion.rotvec)
    assert np.all(jit < 0.6), jit
    assert part.quality["jitter_pitch"] == pytest.approx(jit[0], abs=1e-3)
    # and the pose actually moves (not a frozen output)
    assert np.all(np.degrees(part.motion.rotvec.std(0)) > 0.5)


def _mouth_and_intensity(analysis):
    lm = analysis.landmarks
    P = lm.points.astype(float)
    eyes = np.linalg.norm(P[:, 33, :2] - P[:, 263, :2], axis=1)
    mouth = np.mean([np.linalg.norm(P[:, u, :2] - P[:, d, :2], axis=1)
                     for u, d in ((13, 14), (82, 87), (312, 317))], axis=0) / eyes
    mouth = np.where(np.isfinite(mouth), mouth, np.nanmedian(mouth))
    x, sr = analysis.audio.samples, analysis.audio.sample_rate
    t = lm.times - lm.times[0]
    half = 0.5 / analysis.fps
    rms = np.array([np.sqrt(np.mean(x[max(0, int((ti - half) * sr)):max(1, int((ti + half) * sr))] ** 2))
                    for ti in t])
    return mouth, 20 * np.log10(np.maximum(rms, 1e-4))


def _xcorr(m, i, max_lag):
    n = len(m)
    out = []
    for lag in range(-max_lag, max_lag + 1):  # lag > 0: the audio comes later than the mouth
        a, b = m[max(0, -lag):n - max(0, lag)], i[max(0, lag):n - max(0, -lag)]
        out.append(np.corrcoef(a, b)[0, 1])
    return np.array(out)


@pytest.mark.slow
def test_audio_video_sync_within_one_frame(grid_analyses, french):
    """Mouth opening and speech intensity correlate best within ±1 frame of zero lag (averaged
    over the 11 GRID sentences and 8 s of the French clip, whose video starts 80 ms after its
    audio); an artificial 4-frame audio delay moves the peak to +4."""
    L = 8
    total = np.zeros(2 * L + 1)
    shifted = np.zeros(2 * L + 1)
    for a in grid_analyses + [french]:
        m, i = _mouth_and_intensity(a)
        total += _xcorr(m, i, L)
        i_late = np.concatenate([np.full(4, i[0]), i[:-4]])
        shifted += _xcorr(m, i_late, L)
    assert abs(int(np.argmax(total)) - L) <= 1, np.round(total / (len(grid_analyses) + 1), 2)
    assert abs(int(np.argmax(shifted)) - L - 4) <= 1
    assert total.max() / (len(grid_analyses) + 1) > 0.3


@pytest.mark.slow
def test_grid_mpg_with_mp2_audio_gives_aligned_recordings(grid_analyses):
    from headmotion.corpus import Recording

    for a in grid_analyses:
        part = _one_part(a)
        rec = Recording.aligned(part.id, "s", "video", part.audio, part.motion)
        assert rec.motion.fps == 25.0 and rec.duration == pytest.approx(3.0, abs=0.1)


def test_non_integer_frame_rate_uses_timestamps(tv):
    from headmotion.video.build import analyse_video

    a = analyse_video(tv / "video_retalking" / "1.mp4", max_frames=40)
    assert a.fps == pytest.approx(1350 / 61, rel=1e-3)  # ≈ 22.13 fps
    part = _one_part(a, min_part_s=1.0)
    assert part.motion.fps == pytest.approx(22.131, abs=1e-2)
    part25 = _one_part(a, fps=25.0)
    assert part25.motion.fps == 25.0
    assert part25.motion.duration == pytest.approx(part.motion.duration, abs=0.05)


def test_styletalk_video_without_audio_uses_same_named_wav(tv, tmp_path):
    from headmotion.video.build import analyse_video

    src = tv / "styletalk" / "feifeili_clip3.mp4"
    a = analyse_video(src, max_frames=45)
    assert a.audio_source.endswith("feifeili_clip3.wav")
    # copied alone (no .wav beside it): a clear message
    lonely = tmp_path / "lonely.mp4"
    lonely.write_bytes(src.read_bytes())
    with pytest.raises(FormatError, match="no audio track.*--audio"):
        analyse_video(lonely)


def _write_video(path, frames, fps=25):
    import av

    with av.open(str(path), "w") as c:
        s = c.add_stream("mpeg4", rate=fps)
        s.height, s.width = frames[0].shape[:2]
        s.pix_fmt = "yuv420p"
        for im in frames:
            for pkt in s.encode(av.VideoFrame.from_ndarray(np.ascontiguousarray(im), format="rgb24")):
                c.mux(pkt)
        for pkt in s.encode():
            c.mux(pkt)


@pytest.fixture(scope="session")
def speech_wav(tmp_path_factory, french):
    from headmotion.io import save_audio

    p = tmp_path_factory.mktemp("speech") / "speech.wav"
    save_audio(french.audio, p)
    return p


def test_bad_inputs_give_clear_messages(tmp_path, french_frames, speech_wav):
    from headmotion.video.build import analyse_video, parts_from_analysis

    rng = np.random.default_rng(0)
    # no face at all
    noface = tmp_path / "noface.mp4"
    _write_video(noface, [rng.integers(0, 255, (128, 128, 3), dtype=np.uint8) for _ in range(30)])
    a = analyse_video(noface, audio=speech_wav)
    with pytest.raises(FormatError, match="no face found"):
        parts_from_analysis(a, rec_id="noface")
    # a one-frame video
    one = tmp_path / "one.mp4"
    _write_video(one, [french_frames[0][1]])
    a = analyse_video(one, audio=speech_wav)
    assert len(a.landmarks) == 1
    with pytest.raises(FormatError, match="only 1 frame"):
        parts_from_analysis(a, rec_id="one")
    # a truncated file keeps what decodes or says it cannot
    good = tmp_path / "good.mp4"
    _write_video(good, [im for _, im in french_frames[:20]])
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(good.read_bytes()[:600])
    with pytest.raises(FormatError, match="cut.mp4"):
        analyse_video(cut, audio=speech_wav)


def test_two_faces_and_face_leaving_frame(tmp_path, french_frames, speech_wav):
    from headmotion.video.build import analyse_video, parts_from_analysis

    frames = [im[::2, ::2] for _, im in french_frames[:50]]  # 256²
    # two faces side by side
    two = tmp_path / "two.mp4"
    _write_video(two, [np.hstack([im, im[:, ::-1]]) for im in frames])
    a = analyse_video(two, audio=speech_wav)
    assert np.mean(a.landmarks.n_faces == 2) > 0.5
    part = parts_from_analysis(a, rec_id="two")[0]
    assert "two faces" in part.quality["note"]
    assert np.all(np.degrees(np.abs(part.motion.rotvec)) < 30)  # no garbage from switching faces
    # the face slides out of the frame to the right and stays out
    leave = tmp_path / "leave.mp4"
    out = []
    for k, im in enumerate(frames):
        shift = int(max(0, k - 25) * 14)
        canvas = np.zeros_like(im)
        if shift < im.shape[1]:
            canvas[:, shift:] = im[:, :im.shape[1] - shift]
        out.append(canvas)
    _write_video(leave, out)
    a = analyse_video(leave, audio=speech_wav)
    parts = parts_from_analysis(a, rec_id="leave")
    assert len(parts) == 1
    assert parts[0].stop <= 40  # frames with the face (partly) outside are not used
    assert parts[0].motion.duration >= 1.0


def test_cli_from_video_writes_a_loadable_corpus(tv, tmp_path):
    from headmotion.cli import main
    from headmotion.corpus import Corpus

    vids = [tv / "grid" / "bbaf2n.mpg", tv / "grid" / "lbax4n.mpg"]
    out = tmp_path / "corpus"
    code = main(["corpus", "from-video", *map(str, vids), "-o", str(out), "--speaker", "gridpeople", "--fps", "25"])
    assert code == 0
    c = Corpus.load(out)
    assert c.ids == ["bbaf2n", "lbax4n"] and c.speakers == ["gridpeople"] and c.tasks == ["video"]
    for rec in c:
        assert rec.audio.sample_rate == 16000 and rec.motion.fps == 25.0
        assert abs(rec.audio.duration - rec.motion.duration) < 0.1
    assert (out / "quality.csv").read_text().startswith("recording,")
    # re-running uses the landmark cache and gives the same motion
    before = c[0].motion.rotvec.copy()
    assert main(["corpus", "from-video", str(vids[0]), "-o", str(out), "--speaker", "gridpeople", "--fps", "25"]) == 0
    c2 = Corpus.load(out)
    assert c2.ids == ["bbaf2n", "lbax4n"]
    np.testing.assert_allclose(c2[0].motion.rotvec, before)
    # an unusable input is one clear line and a non-zero exit code
    assert main(["corpus", "from-video", str(tmp_path / "nope.mp4"), "-o", str(out)]) != 0
