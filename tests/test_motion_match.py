"""motion-match: recorded movements chosen by the speech — a known answer (its own training
recording played back), seeded takes, joins without steps, persistence (planted corpus; the
contract checks are in test_contract.py)."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.rotations import rotvec_to_pitch_yaw_roll
from headmotion.systems import create, load_model
from headmotion.motion.angles import centred_degrees
from headmotion.systems.motion_match import FPS
from headmotion.systems.motion_match import speech_descriptors


@pytest.fixture(scope="module")
def corpus(planted):
    return planted(minutes=1.5, n_recordings=3, seed=11)


@pytest.fixture(scope="module")
def model(corpus):
    return create("motion-match", target_weight=1.0, pause_weight=1.0).fit(corpus)


def angles(motion):
    return np.degrees(rotvec_to_pitch_yaw_roll(motion.rotvec))


def test_its_own_training_speech_plays_its_recorded_motion_back(corpus):
    """One recording as the library, no mirror, speech and continuity only (no pose goal or pause
    preference), the nearest match only and leaving a clip costly, in pauses too:
    given that recording's own speech, every decision continues the clip, so the output is the
    recorded motion (mean pose removed) to float precision."""
    one = corpus.subset([0])
    m = create("motion-match", mirror=False, top_k=1, switch_cost=100.0, pause_switch=1.0, target_weight=0.0,
               pause_weight=0.0).fit(one)
    rec = one[0]
    out = angles(m.predict(rec.audio, seed=0))
    truth = centred_degrees(rec.motion, len(out), 25.0)
    np.testing.assert_allclose(out - np.degrees(m.mean_pose_), truth, atol=1e-6)


def test_same_seed_same_motion_other_seed_other_take(model, corpus):
    audio = corpus[2].audio.slice_seconds(0, 20.0)
    a, b, c = (angles(model.predict(audio, seed=s)) for s in (3, 3, 4))
    np.testing.assert_array_equal(a, b)
    assert not np.allclose(a, c)
    # a different take, not one path with an offset
    assert min(abs(np.corrcoef(a[:, k], c[:, k])[0, 1]) for k in range(3)) < 0.9
    np.testing.assert_array_equal(angles(model.predict(audio)), angles(model.predict(audio, seed=model.seed)))


def test_no_step_where_clips_join(model, corpus):
    """Where the playing clip changes, the frame-to-frame step is no larger than the steps a
    recorded motion takes (the join is carried on from where the motion was going)."""
    audio = corpus[1].audio
    n = int(len(audio.samples) / audio.sample_rate * FPS)
    feats = ((model._prosody(audio, n) - model.feat_mean_) / model.feat_std_).astype(np.float32)
    x = model.generate(feats, seed=2)
    step = np.abs(np.diff(x, axis=0)).max(axis=1)
    library_step = np.abs(np.diff(model.lib_motion_, axis=0)).max(axis=1)
    joins = np.arange(model.hop - 1, len(x) - 1, model.hop)
    assert step[joins].max() <= 2.0 * np.quantile(library_step, 0.99)


def test_save_load_gives_identical_motion(model, corpus, tmp_path):
    audio = corpus[1].audio.slice_seconds(0, 6.0)
    back = load_model(model.save(tmp_path / "mm.hmz"))
    np.testing.assert_array_equal(back.predict(audio, seed=2).rotvec, model.predict(audio, seed=2).rotvec)
    assert back.get_params() == model.get_params()


def test_speech_descriptors_look_back_and_ahead():
    f = np.arange(20, dtype=np.float32)[:, None]
    d = speech_descriptors(f, np.array([-2, 0, 3]))
    # smoothed over 5 frames (edges repeated): frame 10 sees frames 8, 10 and 13
    np.testing.assert_allclose(d[10], [8.0, 10.0, 13.0])
    np.testing.assert_allclose(d[0], [0.6, 0.6, 3.0])  # before the start: frame 0 smoothed over 0, 0, 0, 1, 2


@pytest.mark.parametrize("bad", [{"hop": 0}, {"top_k": 0}, {"temperature": 0.0}, {"switch_cost": -1.0},
                                 {"mirror": "yes"}, {"target_weight": float("nan")}, {"goal_path": 1},
                                 {"pause_speed": "yes"}, {"pause_switch": -1.0}, {"live": "yes"},
                                 {"lowpass": 0.2}, {"lowpass": 12.5}, {"posture_s": -1.0}, {"prosody": "mfcc"},
                                 {"prosody": "f0e", "live": True}, {"voicing_threshold": 0.0}, {"voicing_threshold": 1.5},
                                 {"centred": "yes"}, {"pitch_jump": -1.0}])
def test_bad_parameters_are_refused(bad, corpus):
    with pytest.raises(ParameterError, match=list(bad)[-1]):
        create("motion-match", **bad).fit(corpus)


def test_a_tracking_glitch_ends_a_clip():
    """A jump above MAX_STEP_DEG between two library frames (a tracker's glitch) ends the clip
    there: no clip may start so close before it that its hop would play across it."""
    from headmotion.systems.motion_match import MAX_STEP_DEG

    m = create("motion-match", hop=5, mirror=False)
    motion = np.zeros((60, 3), np.float32)
    motion[30:, 1] = 3 * MAX_STEP_DEG  # frames 29 → 30 jump
    m.lib_motion_, m.lib_lengths_ = motion, np.array([60])
    m.lib_feats_ = np.random.default_rng(0).normal(size=(60, 6)).astype(np.float32)
    m._index()
    assert list(m.library_.ends[[0, 29, 30, 59]]) == [30, 30, 60, 60]
    starts = np.flatnonzero(m.library_.can_start)
    assert not np.any((starts + m.hop >= 30) & (starts < 30))   # nothing plays across the jump
    assert 0 in starts and 23 in starts and 24 not in starts and 30 in starts and 53 in starts and 54 not in starts


def test_a_takes_first_movement_is_drawn_from_distinct_clips():
    """The cheapest frames are neighbours in one clip; the first draw of a take chooses among
    frames at least a hop apart (cost = frame index: the candidates are 0, hop, 2·hop, …)."""
    from headmotion.systems.motion_match import Library

    cost = np.arange(100, dtype=float)
    rng = np.random.default_rng(0)
    draw = dict(top_k=3, temperature=100.0, hop=5)
    assert {Library.draw(cost, rng, distinct=True, **draw) for _ in range(200)} == {0, 5, 10}
    assert {Library.draw(cost, rng, **draw) for _ in range(200)} == {0, 1, 2}


def test_the_goal_is_followed_over_the_whole_hop(model, corpus):
    """Matching the goal's path over the hop (goal_path) follows it more closely, frame by frame,
    than matching only where it is at the hop's end — speech and continuity costs off, the
    cheapest candidate taken."""
    audio = corpus[1].audio
    n = int(len(audio.samples) / audio.sample_rate * FPS)
    feats = ((model._prosody(audio, n) - model.feat_mean_) / model.feat_std_).astype(np.float32)
    miss = {}
    for path in (True, False):
        m = create("motion-match", goal_path=path, speech_weight=0.0, pose_weight=0.0, velocity_weight=0.0,
                   switch_cost=0.0, pause_weight=0.0, top_k=1, target_weight=1.0).fit(corpus)
        goal = m.goals(speech_descriptors(feats, m._taps))
        x = m.generate(feats, seed=0)
        ax = m.library_.goal_axes
        assert ax[0] and not ax[1:].any()  # mirrored library: only the pitch has a goal
        miss[path] = np.mean((x[:, ax] - goal[:, ax]) ** 2)
    assert miss[True] < 0.8 * miss[False]


def test_a_model_file_without_goal_path_follows_the_goals_end(model):
    config, arrays = model._get_state()
    del config["params"]["goal_path"]
    back = type(model)()
    back._set_state(config, arrays)
    assert back.goal_path is False


def _pause_library(**params):
    """A library of one recording: 150 frames nodding ±5° with a period of one hop (every hop
    ends where it starts), then 150 still frames; all its speech is silence."""
    m = create("motion-match", hop=15, mirror=False, top_k=1, speech_weight=0.0, target_weight=0.0, **params)
    t = np.arange(300)
    motion = np.zeros((300, 3), np.float32)
    motion[:150, 0] = 5 * np.sin(2 * np.pi * t[:150] / 15)
    m.lib_motion_, m.lib_lengths_ = motion, np.array([300])
    m.lib_feats_ = np.zeros((300, 6), np.float32)
    m.feat_mean_, m.feat_std_ = np.zeros(6), np.ones(6)
    m._index()
    return m


def test_in_a_pause_the_head_holds_still():
    """In a pause the cost is the mean speed over the hop: the still frames are chosen over a nod
    that ends where it started (its net displacement over the hop is zero, as the still frames')."""
    m = _pause_library(pause_speed=True)
    x = m.generate(np.zeros((90, 6), np.float32), seed=0)
    assert np.abs(np.diff(x, axis=0)).max() < 1e-9
    blind = _pause_library(pause_speed=False)
    a2 = blind.library_.tables["A2"]  # net displacement over the hop cannot tell the nod from stillness
    assert a2[:135].max() < 1e-9 and a2[150:].max() < 1e-9


def test_in_a_pause_leaving_the_clip_costs_switch_cost_times_pause_switch():
    """A still head playing the nod at a pause: with pause_switch = 0 it leaves for the still frames
    at the next decision; with the full switch cost (pause_switch = 1, switch cost above what the
    nod costs) it keeps nodding.  (The join's spring has settled by the third hop.)"""
    for pause_switch, still_after in ((0.0, True), (1.0, False)):
        m = _pause_library(pause_speed=True, pause_switch=pause_switch, switch_cost=1e6)
        cost = np.full(len(m.library_.poses), np.inf)
        cost[0] = 0.0  # force the first decision onto the nod
        first = m.library_.draw
        calls = []

        def draw(c, rng, first=first, calls=calls, cost=cost, **kw):
            calls.append(1)
            return first(cost if len(calls) == 1 else c, rng, **kw)

        m.library_.draw = draw
        x = m.generate(np.zeros((60, 6), np.float32), seed=0)
        later = np.abs(np.diff(x[45:], axis=0)).max()
        assert (later < 1e-3) == still_after and (later > 0.5) != still_after


def test_the_goal_stays_among_the_librarys_poses(model, corpus):
    """Speech far from any training speech asks for no pose outside the library's 1st–99th
    percentile; within it the goal is the ridge prediction itself."""
    audio = corpus[1].audio
    n = int(len(audio.samples) / audio.sample_rate * FPS)
    feats = ((model._prosody(audio, n) - model.feat_mean_) / model.feat_std_).astype(np.float32)
    desc = speech_descriptors(feats, model._taps)
    lo, hi = np.percentile(model.library_.poses, [1.0, 99.0], axis=0)
    wild = model.goals(desc * 50.0)
    assert np.all(wild >= lo - 1e-9) and np.all(wild <= hi + 1e-9) and np.any(wild[:, 0] == hi[0])
    raw = np.c_[desc.astype(np.float64), np.ones(n)] @ model.library_.goal_weights
    inside = np.all((raw >= lo) & (raw <= hi), axis=1)
    assert inside.mean() > 0.5
    np.testing.assert_allclose(model.goals(desc)[inside], raw[inside])


@pytest.fixture(scope="module")
def live(corpus):
    return create("motion-match", live=True).fit(corpus)


def test_live_streams_and_the_stream_equals_predict(live, corpus):
    """``live``: the system is causal; pushing the audio in 10 ms chunks gives predict's frames
    exactly, 39 ms behind the audio (the f0e-live features with no lookahead)."""
    audio = corpus[1].audio.slice_seconds(0, 9.0)
    assert live.causal and live.can_stream
    out = live.predict(audio, seed=5)
    st = live.stream(seed=5)
    step = live.sample_rate // 100
    x = audio.samples
    parts = [st.push(x[i:i + step]) for i in range(0, len(x), step)] + [st.flush()]
    np.testing.assert_array_equal(np.concatenate([p.rotvec for p in parts]), out.rotvec)
    assert 30.0 < st.latency_ms < 50.0
    assert not create("motion-match").can_stream


def _streamed(model, audio, chunk: int, seed: int):
    st = model.stream(seed=seed)
    x = audio.samples
    parts = [st.push(x[i:i + chunk]) for i in range(0, len(x), chunk)] + [st.flush()]
    return np.concatenate([p.rotvec.reshape(-1, 3) for p in parts]), st


@pytest.mark.parametrize("lookahead_ms, ahead", [(40.0, 1), (139.0, 3), (400.0, 10)])
@pytest.mark.parametrize("chunk", [160, 4001])
def test_with_a_lookahead_the_stream_equals_predict_and_comes_that_much_later(live, corpus, lookahead_ms, ahead,
                                                                               chunk):
    """``lookahead_ms`` L reads A = floor(L · 25 / 1000) frames ahead: the stream's frames equal
    ``predict``'s with the same L (10 ms and 250 ms chunks, the file's end read as its last row
    repeated in both), its latency grows by A · 40 ms, and the caller's model is not changed."""
    import copy

    audio = corpus[1].audio.slice_seconds(0, 9.0)
    m = copy.copy(live).set_params(lookahead_ms=lookahead_ms)
    assert m._shift == ahead and m.can_stream
    out = m.predict(audio, seed=5)
    got, st = _streamed(m, audio, chunk, seed=5)
    np.testing.assert_allclose(got, out.rotvec, rtol=0, atol=1e-6)
    assert st.latency_ms == pytest.approx(live_latency(live) + 40.0 * ahead)
    assert live.lookahead_ms == 0 and live.library_.shift == 0 and m.library_.shift == ahead
    assert not np.allclose(out.rotvec, live.predict(audio, seed=5).rotvec)


def test_a_file_shorter_than_the_lookahead_streams_as_predict_reads_it(live, corpus):
    """A file shorter than the lookahead (0.3 s against 1.08 s): every decision reads past the
    end, the last row repeated, in the stream as in ``predict``."""
    import copy

    m = copy.copy(live).set_params(lookahead_ms=1080.0)
    for seconds in (0.3, 1.5):
        audio = corpus[0].audio.slice_seconds(2.0, 2.0 + seconds)
        out = m.predict(audio, seed=1)
        got, _ = _streamed(m, audio, 160, seed=1)
        assert len(out) == round(seconds * FPS)
        np.testing.assert_allclose(got, out.rotvec, rtol=0, atol=1e-6)


def test_with_a_lookahead_a_decision_reads_the_speech_that_far_ahead_and_no_further(live, corpus):
    """With A frames of lookahead, changing the audio after 5 s leaves every frame up to A frames
    before the first one whose features read it unchanged, and changes later ones."""
    import copy

    m = copy.copy(live).set_params(lookahead_ms=200.0)  # A = 5
    audio = corpus[1].audio.slice_seconds(0, 10.0)
    other = audio.samples.copy()
    cut = int(5.0 * audio.sample_rate)
    other[cut:] = corpus[0].audio.samples[cut:len(other)]
    a = angles(m.predict(audio, seed=1))
    b = angles(m.predict(type(audio)(other, audio.sample_rate), seed=1))
    first = int((5.0 - 0.040) * FPS) - 5  # frames whose decisions read only features ending before the cut
    first -= first % m.hop  # a decision's frames come together
    np.testing.assert_array_equal(a[:first], b[:first])
    assert not np.allclose(a[first:], b[first:])


def test_the_librarys_descriptors_read_as_far_ahead_as_the_query(live):
    """Re-indexed for a lookahead of A frames, each library frame's descriptor is the causal one of
    the frame A later (within its recording; past the end its last row repeated) over taps that
    still reach ``context`` frames back from the frame itself — the speech ahead is added, the
    speech around the frame kept — and the goal's regression is fitted on them."""
    import copy

    from headmotion.systems.motion_match import read_ahead

    m = copy.copy(live).set_params(lookahead_ms=120.0)  # A = 3
    m._indexed()
    assert m._taps.min() == live._taps.min() - 3 and m._taps.max() == 0
    n = int(live.lib_lengths_[0])
    f = live.lib_feats_[:n]
    want = speech_descriptors(read_ahead(f, 3), m._taps, causal=True)[3:]
    np.testing.assert_allclose(m.library_.descriptors[:n], want, atol=1e-6)
    assert not np.allclose(m.library_.goal_weights, live.library_.goal_weights)
    assert copy.copy(live).set_params(lookahead_ms=130.0)._library_for(3) is m.library_  # built once, shared


def test_a_lookahead_is_refused_on_a_model_that_is_not_live(corpus):
    """A model that is not ``live`` reads ahead already (its ``lookahead``): a non-zero
    ``lookahead_ms`` is refused, naming what it reads; a negative one is refused on any model."""
    m = create("motion-match", prosody="f0e-live", hop=4).fit(corpus)
    with pytest.raises(ParameterError, match="not live and already reads"):
        m.set_params(lookahead_ms=200.0).predict(corpus[0].audio.slice_seconds(0, 1.0))
    with pytest.raises(ParameterError, match="lookahead_ms"):
        create("motion-match", live=True, lookahead_ms=-40.0).fit(corpus)


def test_live_decisions_read_no_speech_after_their_frame(live, corpus):
    """Changing the audio after 5 s leaves every frame up to the one whose features read it
    unchanged (the features' 39 ms), and changes frames after it."""
    audio = corpus[1].audio.slice_seconds(0, 10.0)
    other = audio.samples.copy()
    cut = int(5.0 * audio.sample_rate)
    other[cut:] = corpus[0].audio.samples[cut:len(other)]
    a = angles(live.predict(audio, seed=1))
    b = angles(live.predict(type(audio)(other, audio.sample_rate), seed=1))
    first = int((5.0 - 0.040) * FPS)  # frames whose features end before the cut
    np.testing.assert_array_equal(a[:first], b[:first])
    assert not np.allclose(a[first + live.hop:], b[first + live.hop:])


def test_causal_descriptor_of_the_last_frame_equals_the_whole_tracks():
    """descriptor_of_last on the rows up to a frame equals the causal descriptor computed over the
    whole track, at the start (edges repeated) and later."""
    from headmotion.systems.motion_match import descriptor_of_last

    f = np.random.default_rng(0).normal(size=(40, 3)).astype(np.float32)
    taps = np.array([-10, -5, 0])
    whole = speech_descriptors(f, taps, causal=True)
    for t in (0, 3, 14, 39):
        np.testing.assert_allclose(descriptor_of_last(f[:t + 1], taps), whole[t], rtol=1e-6, atol=1e-6)
    # causal: the frame's own descriptor does not change when later frames do
    g = f.copy()
    g[20:] += 5.0
    np.testing.assert_array_equal(speech_descriptors(g, taps, causal=True)[:20], whole[:20])


@pytest.fixture(scope="module")
def windowed(corpus):
    return create("motion-match", prosody="f0e-live", lowpass=4.0, posture_s=3.0).fit(corpus)


@pytest.mark.parametrize("chunk", [160, 4001])
def test_on_f0e_live_prosody_it_streams_with_lookahead_and_the_stream_equals_predict(windowed, corpus, chunk):
    """Not live, on the f0e-live prosody: the system streams with the lookahead its decisions
    read (the features' 39 ms + hop + lookahead + 2 frames at 25 fps) and the stream's frames equal
    predict's bit for bit, whatever the chunking."""
    audio = corpus[1].audio.slice_seconds(0, 9.0)
    assert windowed.can_stream and not windowed.causal
    out = windowed.predict(audio, seed=5)
    st = windowed.stream(seed=5)
    x = audio.samples
    parts = [st.push(x[i:i + chunk]) for i in range(0, len(x), chunk)] + [st.flush()]
    np.testing.assert_array_equal(np.concatenate([p.rotvec for p in parts]), out.rotvec)
    ahead = windowed.hop + windowed.lookahead + 2
    assert st.latency_ms == pytest.approx(live_latency(windowed) + 1000.0 * ahead / FPS)


@pytest.mark.parametrize("live", [False, True])
def test_centred_features_and_a_lenient_voicing_threshold_keep_the_stream_equal_to_predict(corpus, live):
    """``centred`` reads the features' smoothing and deltas 200 ms ahead (5 frames at 25 fps): the
    stream comes that much later, and still equals ``predict`` bit for bit; a lenient
    ``voicing_threshold`` calls more frames voiced."""
    from headmotion.features.streaming import StreamingF0e
    from headmotion.systems.motion_match import CENTRED_FEATURES

    m = create("motion-match", prosody="f0e-live", live=live, hop=4 if live else 15, centred=True,
               voicing_threshold=0.45).fit(corpus)
    audio = corpus[1].audio.slice_seconds(0, 8.0)
    out = m.predict(audio, seed=2)
    st = m.stream(seed=2)
    x = audio.samples
    parts = [st.push(x[i:i + 480]) for i in range(0, len(x), 480)] + [st.flush()]
    np.testing.assert_array_equal(np.concatenate([p.rotvec for p in parts]), out.rotvec)
    assert st.latency_ms >= live_latency(m) + 200.0 - 1e-6
    strict = StreamingF0e(sample_rate=16000, fps=FPS, voicing=True)
    lenient = StreamingF0e(sample_rate=16000, fps=FPS, voicing=True, voicing_threshold=0.45)
    voiced = [np.vstack([e.push(audio.samples), e.flush()])[:, -1].mean() for e in (strict, lenient)]
    assert voiced[1] > voiced[0]
    assert CENTRED_FEATURES == {"smooth_lookahead": 1, "delta_lookahead": 2}


def live_latency(model) -> float:
    from headmotion.features.streaming import StreamingF0e
    from headmotion.systems.motion_match import LIVE_FEATURES

    return StreamingF0e(sample_rate=model.sample_rate, fps=FPS, **LIVE_FEATURES).latency_ms


def test_the_windowed_decisions_equal_the_whole_file_ones(corpus):
    """On the f0e-live prosody a decision's inputs come from a window around it; they equal the
    descriptors, goals and pause test computed over the whole track (the window reaches as far as
    a decision reads)."""
    m = create("motion-match", prosody="f0e-live").fit(corpus)
    audio = corpus[2].audio.slice_seconds(0, 12.0)
    n = int(12.0 * FPS)
    f = ((m._prosody(audio, n) - m.feat_mean_) / m.feat_std_).astype(np.float32)
    desc = speech_descriptors(f, m._taps)
    back, ahead = m._reach
    for t in (0, 15, 150, n - 15):
        lo = max(0, t - back)
        d, goal, _ = m.window_inputs(f[lo:t + ahead + 1], t - lo)
        np.testing.assert_allclose(d, desc[t], atol=1e-5)
        np.testing.assert_allclose(goal, m.goals(desc[np.minimum(t + m._goal_steps, n - 1)]), atol=1e-4)


def test_lowpass_removes_the_trackers_jitter_and_keeps_a_nod(corpus):
    """``lowpass``: a 1 Hz nod with a tracker's frame-to-frame jitter on top (±1°, alternating) is
    kept as the nod alone (the jitter's reversals gone, the nod's amplitude kept within 5 %), each
    clip on its own (a glitch still ends a clip); the model keeps the cleaned clips."""
    from headmotion.systems.motion_match import MAX_STEP_DEG, clean_clips, clip_starts

    t = np.arange(250) / FPS
    nod = 5.0 * np.sin(2 * np.pi * 1.0 * t)
    rec = np.c_[nod + 1.0 * (-1.0) ** np.arange(250), np.zeros((250, 2))]
    rec[200:, 1] += 3 * MAX_STEP_DEG  # a glitch: a second clip from frame 200
    starts = clip_starts(rec)
    assert list(np.flatnonzero(starts)) == [0, 200]
    played = clean_clips(rec, starts, 4.0)
    inner = slice(25, 175)
    assert np.abs(played[inner, 0] - nod[inner]).max() < 0.25
    assert np.ptp(played[inner, 0]) == pytest.approx(np.ptp(nod[inner]), rel=0.05)
    reversals = [(np.sign(np.diff(x)[1:]) * np.sign(np.diff(x)[:-1]) < 0).mean() for x in (played[:200, 0], rec[:200, 0])]
    assert reversals[0] < 0.1 and reversals[1] > 0.9
    np.testing.assert_allclose(played[200:, 1], 3 * MAX_STEP_DEG, atol=1e-9)  # the glitch is not smeared
    m = create("motion-match", lowpass=4.0).fit(corpus)
    raw = create("motion-match").fit(corpus)
    removed = m.lib_motion_ - raw.lib_motion_  # what the filter took: small, not nothing
    assert 0 < removed.std() < 0.2 * raw.lib_motion_.std()
    np.testing.assert_array_equal(m.lib_starts_, raw.lib_starts_)


def test_posture_s_keeps_a_reached_posture_for_seconds():
    """At a join the pose offset settles over ``posture_s`` (a posture is kept), the velocity over
    the blend: with posture_s = 4 s an offset of 6° is still 6·exp(−1/4) ≈ 4.7° one second on;
    with the spring (posture_s = 0) it is gone within the blend."""
    from headmotion.systems.motion_match import _Walk

    for posture_s, after_1s in ((4.0, 6.0 * np.exp(-0.25)), (0.0, 0.0)):
        m = create("motion-match", hop=25, blend=8, posture_s=posture_s, mirror=False)
        m.lib_motion_ = np.zeros((200, 3), np.float32)
        m.lib_lengths_ = np.array([200])
        m.lib_feats_ = np.zeros((200, 6), np.float32)
        m._index()
        w = _Walk(m, 0)
        w.t, w.pos, w.last = 25, -1, np.array([[6.0, 0.0, 0.0], [6.0, 0.0, 0.0]])
        frames = w.hop(np.zeros(m.library_.descriptors.shape[1], np.float32), None, 1.0, 26)
        assert frames[0, 0] == pytest.approx(6.0)  # no step at the join
        assert frames[25, 0] == pytest.approx(after_1s, abs=1e-3)


def test_repeat_cost_keeps_a_take_from_looping_over_the_same_clips(model):
    """Ten seconds of one unchanging input (a long silence asks the same question every hop):
    without memory the walk may start the same few clips again and again; with a large
    ``repeat_cost`` no clip starts within a hop of one started in the last REPEAT_S seconds."""
    from headmotion.systems.motion_match import REPEAT_S, _Walk

    feats = np.repeat(model.lib_feats_[:1], 300, axis=0)  # one frame's prosody, held
    H = int(model.hop)
    for cost, loops_allowed in ((0.0, True), (1e6, False)):
        model.set_params(repeat_cost=cost)
        try:
            walk = _Walk(model, 0)
            starts = []
            for t in range(0, len(feats), H):
                pos = walk.pos
                walk.hop(*model.window_inputs(feats[max(0, t - 20):t + 40], min(t, 20)), H)
                if walk.pos - H != pos:
                    starts.append((t, walk.pos - H))
            close = [(a, b) for i, a in enumerate(starts) for b in starts[:i]
                     if a[0] - b[0] < REPEAT_S * FPS and abs(a[1] - b[1]) < H]
            assert bool(close) == loops_allowed  # the held input does loop without memory
        finally:
            model.set_params(repeat_cost=0.0)


def test_with_ease_in_every_take_opens_at_the_mean_pose_at_rest(corpus):
    """``ease_in``: the first movement is chosen as if the head were at the mean pose, at rest, and
    the offset to it settles as a critically damped spring: frame 0 is the mean pose and the
    first step is small; without it a take opens at its first clip's own pose."""
    eased = create("motion-match", prosody="f0e-live", ease_in=0.3).fit(corpus)
    plain = create("motion-match", prosody="f0e-live").fit(corpus)
    audio = corpus[2].audio.slice_seconds(0, 6.0)
    opened_away = 0
    for seed in range(4):
        a = angles(eased.predict(audio, seed=seed)) - np.degrees(eased.mean_pose_)
        np.testing.assert_allclose(a[0], 0.0, atol=1e-9)
        assert np.abs(np.diff(a[:3], axis=0)).max() < 1.0  # eased: a slow start, not a jump
        b = angles(plain.predict(audio, seed=seed)) - np.degrees(plain.mean_pose_)
        opened_away += np.abs(b[0]).max() > 0.5
    assert opened_away >= 2  # the plain model's takes open at their clips' poses
    with pytest.raises(ParameterError, match="ease_in"):
        create("motion-match", ease_in=-1.0).fit(corpus)


def test_cheapest_are_the_k_smallest_in_cost_then_library_order():
    """``cheapest`` against a full sort by (cost, index), with ties, infinities, fewer finite costs
    than a stride's sample would hold and arrays shorter than the stride."""
    from headmotion.systems.motion_match.library import STRIDE, cheapest

    rng = np.random.default_rng(3)
    for n, k in [(21014, 8), (5000, 1), (300, 8), (STRIDE * 8 - 1, 8), (10, 4)]:
        for _ in range(20):
            cost = np.round(rng.random(n) * 20, 1)  # many ties
            cost[rng.random(n) < 0.3] = np.inf
            want = np.lexsort((np.arange(n), cost))[:k]
            np.testing.assert_array_equal(cheapest(cost, k), want)
    cost = np.full(1000, np.inf)
    cost[[7, 500, 999]] = [2.0, 1.0, 2.0]  # fewer finite costs than every STRIDE-th entry shows
    np.testing.assert_array_equal(cheapest(cost, 3), [500, 7, 999])


def test_the_librarys_percentiles_are_numpys_bit_for_bit_without_importing_numpy_ma():
    import subprocess
    import sys

    from headmotion.systems.motion_match.library import percentiles

    rng = np.random.default_rng(0)
    for n in (1, 2, 3, 5, 100, 101, 21014):
        for x in (rng.standard_normal((n, 3)) * 7.0, np.round(rng.standard_normal((n, 3)), 1)):
            for qs in ((1.0, 99.0), (0.0, 100.0), (50.0,), (12.5, 99.9)):
                np.testing.assert_array_equal(percentiles(x, qs), np.percentile(x, qs, axis=0))
    code = ("import sys, numpy as np; from headmotion.systems.motion_match.library import percentiles; "
            "percentiles(np.arange(30.0).reshape(10, 3), (1.0, 99.0)); print('numpy.ma' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
