"""The listening head: Ward & Tsukahara's cue rule on constructed pitch tracks (known answers),
nods cut from the recorded library, and the listening layer offline and on a stream."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.listener.cues import CueDetector, CueRule, detect_cues

FPS = 100
EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "speech"


def speech_track(seconds: float, lo: float = 150.0, hi: float = 250.0):
    """Voiced frames whose pitch spreads evenly over ``lo``–``hi`` Hz without dwelling low: frame k
    at the fractional part of k times the golden ratio (no two frames in a row in the lowest
    quarter of the range, so no region of low pitch)."""
    k = np.arange(1, int(round(seconds * FPS)) + 1)
    f = lo + (hi - lo) * np.modf(k * 0.6180339887)[0]
    return np.log(f), np.ones(len(k), bool)


def low(seconds: float, hz: float = 110.0):
    n = int(round(seconds * FPS))
    return np.full(n, np.log(hz)), np.ones(n, bool)


def silence(seconds: float):
    n = int(round(seconds * FPS))
    return np.zeros(n), np.zeros(n, bool)


def track(*parts):
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def test_a_low_region_after_speech_is_a_cue_due_700_ms_after_its_start():
    lf, v = track(speech_track(2.0), low(0.2), speech_track(1.0))
    assert detect_cues(lf, v) == [(2.0, 2.7)]


def test_the_region_must_last_110_ms():
    lf, v = track(speech_track(2.0), low(0.10), speech_track(1.0))
    assert detect_cues(lf, v) == []
    lf, v = track(speech_track(2.0), low(0.11), speech_track(1.0))
    assert detect_cues(lf, v) == [(2.0, 2.7)]


def test_the_region_must_come_after_700_ms_of_speech():
    # 2 s of speech set the speaker's level; after a pause a new run of speech begins
    for run, expected in ((0.6, []), (0.8, [(3.3, 4.0)])):
        lf, v = track(speech_track(2.0), silence(0.5), speech_track(run), low(0.2), speech_track(0.5))
        start = 2.5 + run
        got = detect_cues(lf, v)
        assert got == [(round(start, 2), round(start + 0.7, 2))] if expected else got == []


def test_no_cue_within_800_ms_of_a_back_channel():
    # first region at 2.0 s (back-channel at 2.7 s); a second region qualifies 110 ms after its start
    for gap, n in ((1.3, 1), (1.5, 2)):
        lf, v = track(speech_track(2.0), low(0.2), speech_track(gap - 0.2), low(0.2), speech_track(0.5))
        cues = detect_cues(lf, v)
        assert len(cues) == n, (gap, cues)
        if n == 2:
            assert cues[1] == (round(2.0 + gap, 2), round(2.7 + gap, 2))


def test_the_level_is_the_speakers_26th_percentile():
    # a speaker whose pitch is 150-250 Hz: 160 Hz is below the level, 200 Hz is not
    det = CueDetector()
    det.push(*speech_track(3.0))
    assert 150.0 < det.level() < 200.0
    lf, v = track(speech_track(2.0), low(0.2, hz=200.0), speech_track(1.0))
    assert detect_cues(lf, v) == []


def test_nothing_before_the_level_is_known_and_an_unvoiced_frame_ends_a_region():
    det = CueDetector()
    det.push(*speech_track(0.25))
    assert det.level() is None                           # less than 0.3 s of voiced speech heard
    strict = CueRule(prior_min_voiced_s=1.0)
    lf, v = track(speech_track(0.8), low(0.2))
    assert detect_cues(lf, v, rule=strict) == []
    lf, v = track(speech_track(2.0), low(0.06), silence(0.01), low(0.06), speech_track(1.0))
    assert detect_cues(lf, v) == []                      # two regions of 60 ms, not one of 130


def test_before_a_second_of_speech_the_level_leans_on_the_prior():
    # 0.8 s of a 150-250 Hz voice: the level is the percentile blended with 1.6 semitones below
    # the median (about 182 Hz), weighted 0.8 : 1
    det = CueDetector()
    det.push(*speech_track(0.8))
    med, pct = 200.0 * 2 ** (-1.6 / 12), 176.0
    assert abs(det.level() - np.exp((0.8 * np.log(pct) + 1.0 * np.log(med)) / 1.8)) < 3.0
    lf, v = track(speech_track(0.8), low(0.2))
    assert detect_cues(lf, v) == [(0.8, 1.5)]            # so a low region after 0.8 s is a cue


def test_the_level_follows_a_new_voice_after_a_turn_change():
    # 10 s of a low voice (100-160 Hz), 2 s of silence, then a high voice (250-400 Hz) whose low
    # region at 260 Hz is below its own 26th percentile (289 Hz) but far above the low voice's
    lf, v = track(speech_track(10.0, 100.0, 160.0), silence(2.0), speech_track(3.0, 250.0, 400.0), low(0.2, hz=260.0),
                  speech_track(1.0, 250.0, 400.0))
    assert detect_cues(lf, v) == [(15.0, 15.7)]
    pooled = CueRule(level_half_life_s=0, turn_keep=1.0)  # every voice heard since the start, alike
    assert detect_cues(lf, v, rule=pooled) == []


def test_pushing_frame_by_frame_gives_the_same_cues():
    lf, v = track(speech_track(2.0), low(0.2), speech_track(1.6), low(0.3), speech_track(0.4))
    det = CueDetector()
    one = [c for i in range(len(lf)) for c in det.push(lf[i:i + 1], v[i:i + 1])]
    assert one == detect_cues(lf, v) and len(one) == 2


def test_the_rule_refuses_bad_parameters():
    with pytest.raises(ParameterError, match="low_percentile"):
        CueRule(low_percentile=0)
    with pytest.raises(ParameterError, match="delay_s"):
        CueRule(delay_s=-1)


def test_nods_are_found_by_their_pitch_velocity():
    from headmotion.listener.nods import find_nods

    fps = 25.0
    x = np.zeros((60, 3))
    # the head goes 4° down over 4 frames and comes back over 4 (frames 20-28)
    x[20:29, 0] = [0, 1, 2, 3, 4, 3, 2, 1, 0]
    assert find_nods(x, fps) == [(20, 29)]
    x[20:29, 1] = np.linspace(0, 6, 9)  # with a large turn it is no nod
    assert find_nods(x, fps) == []
    y = np.zeros((60, 3))
    y[20:29, 0] = [0, -1, -2, -3, -4, -3, -2, -1, 0]  # up then down: no (downward) nod
    assert find_nods(y, fps) == []


def test_the_nods_are_the_recorded_library_movements():
    from headmotion.listener.nods import NodBank, nod_curve, recorded_motion
    from headmotion.synthesis import load_model

    model = load_model("stream")
    bank = NodBank.from_model(model)
    recs, fps = recorded_motion(model)
    assert fps == 25.0 and len(bank) >= 20
    for curve, (r, a) in zip(bank.nods, bank.source):
        np.testing.assert_array_equal(curve, nod_curve(recs[r][a:a + len(curve)]))
        assert np.all(curve[0] == 0) and np.allclose(curve[-1], 0)
    assert np.median(bank.depths()) > 1.0


def _conversation():
    from headmotion.io import load_audio
    from headmotion.types import Audio

    sr = 16000
    a = load_audio(EXAMPLES / "speech_female.wav", sample_rate=sr).samples
    b = load_audio(EXAMPLES / "speech_male.wav", sample_rate=sr).samples
    gap = np.zeros(sr // 2, np.float32)
    za, zb = np.zeros_like(a), np.zeros_like(b)
    own = np.concatenate([a[:5 * sr], gap, zb, gap, a[5 * sr:], gap])
    heard = np.concatenate([np.zeros(5 * sr, np.float32), gap, b, gap, za[5 * sr:], gap])
    return Audio(own, sr), Audio(heard, sr), (5.5, 5.5 + len(b) / sr)


def test_the_listening_head_nods_while_the_other_speaks_and_never_jumps():
    from headmotion.synthesis import synthesize
    from headmotion.types import Audio

    own, heard, (b0, b1) = _conversation()
    base = synthesize(own, "stream", seed=0)[0]
    lis = synthesize(own, "stream", seed=0, hear=heard)[0]
    nods = np.array(lis.meta["nod_frames"]) / lis.fps
    assert len(nods) >= 1 and np.all((nods > b0) & (nods < b1 + 1.0))
    d = np.degrees(lis.rotvec - base.rotvec)
    assert np.all(d[: int(b0 * lis.fps)] == 0)          # before the other speaks: the model's frames
    assert np.abs(d).max() > 2.0                         # it listens
    # the posture and the calm ease in and out: outside the nods no step is larger than the model's own
    # largest, and the nods are no jumps either (a recorded nod's steps)
    step = np.abs(np.diff(lis.as_pitch_yaw_roll(degrees=True), axis=0)).max(axis=1)
    own_step = np.abs(np.diff(base.as_pitch_yaw_roll(degrees=True), axis=0)).max()
    in_nod = np.zeros(len(step), bool)
    for a, b in lis.meta["nod_spans"]:
        in_nod[max(0, a - 1):b] = True
    assert step[~in_nod].max() <= own_step and step.max() <= 2.0 * own_step
    # while the other speaks the head's own nodding movement (pitch, outside its nods) is calmer than
    # the model's; its turns and tilts are not calmed (within the posture's easing, as lively)
    span = np.zeros(len(step), bool)
    span[int((b0 + 1.0) * lis.fps):int(b1 * lis.fps)] = True
    pyr, base_pyr = lis.as_pitch_yaw_roll(degrees=True), base.as_pitch_yaw_roll(degrees=True)
    moved = np.abs(np.diff(pyr, axis=0))[span & ~in_nod].sum(axis=0)
    base_moved = np.abs(np.diff(base_pyr, axis=0))[span & ~in_nod].sum(axis=0)
    assert moved[0] < 0.5 * base_moved[0]
    np.testing.assert_allclose(moved[1:], base_moved[1:], rtol=0.25)
    silent = synthesize(own, "stream", seed=0, hear=Audio(np.zeros_like(heard.samples), 16000))[0]
    np.testing.assert_array_equal(silent.rotvec, base.rotvec)
    none = synthesize(own, "stream", seed=0, hear=heard, listening=0)[0]
    np.testing.assert_array_equal(none.rotvec, base.rotvec)


def test_the_waiting_heads_slow_sways_are_calmed_while_it_listens():
    """A waiting head that sways 5° up and down once every 2 s (the kind of sway the ruler reads as
    a nod) keeps at most a fifth of it while the other speaks: the calm is about a slow course that
    does not follow sways this slow.  Its yaw is left as it was."""
    from headmotion.listener.head import ListeningLayer
    from headmotion.synthesis import load_model

    model = load_model("stream")
    own, heard, (b0, b1) = _conversation()
    fps = model.frame_rate
    t = np.arange(int(len(heard.samples) / 16000 * fps)) / fps
    sway = np.radians(5.0) * np.sin(2 * np.pi * 0.5 * t)
    rv = np.stack([sway, 0.5 * sway, np.zeros_like(t)], axis=1)
    layer = ListeningLayer(model, fps=fps, speech_rate=16000, heard_rate=16000, seed=1)
    layer.hear(heard.samples)
    layer.speech(np.zeros(len(heard.samples), np.float32))  # this head is silent throughout
    out = np.asarray(layer.apply(rv, 0)).reshape(-1, 3)
    span = np.zeros(len(t), bool)
    span[int((b0 + 2.0) * fps):int(b1 * fps)] = True  # listening at full weight
    for a, b in layer.nod_spans:
        span[max(0, a - 5):b + 5] = False
    assert span.sum() > 4 * fps
    wave = lambda x: x[span] - np.convolve(x, np.ones(50) / 50, mode="same")[span]  # about a 2 s mean
    assert np.ptp(wave(out[:, 0])) < 0.2 * np.ptp(wave(rv[:, 0]))
    np.testing.assert_allclose(np.ptp(wave(out[:, 1])), np.ptp(wave(rv[:, 1])), rtol=0.1)


def test_the_stream_hears_as_the_offline_head_does():
    from headmotion.synthesis import open_stream, synthesize

    own, heard, _ = _conversation()
    off = synthesize(own, "stream", seed=2, hear=heard)[0]
    s = open_stream("stream", seed=2)
    x, y, parts = own.samples, heard.samples, []
    for i in range(0, len(x), 320):
        s.hear(y[i:i + 320])
        parts.append(s.push(x[i:i + 320]).rotvec)
    parts.append(s.flush().rotvec)
    np.testing.assert_array_equal(np.vstack(parts), off.rotvec)


def test_the_layer_analyses_in_batches_and_gives_the_frames_of_analysis_on_arrival():
    """The heard audio is analysed when frames reach it, in batches; the frames are those of a
    layer that analyses each chunk as it arrives — heard on time, and heard 0.2 s and 0.5 s late."""
    from headmotion.listener.head import ListeningLayer
    from headmotion.synthesis import load_model
    from headmotion.types import Audio

    model = load_model("stream")
    own, heard, _ = _conversation()

    class OnArrival(ListeningLayer):
        def hear(self, samples):
            super().hear(samples)
            self._analyse_heard()

    when = []  # the sample at which each analysis of the last run came

    def run(cls, lag, own=own, heard=heard):
        layer = cls(model, fps=model.frame_rate, speech_rate=16000, heard_rate=16000, seed=1)
        calls, at = [], [0]
        when.clear()
        push = layer._pitch.push
        layer._pitch.push = lambda x: calls.append(len(x)) or when.append(at[0]) or push(x)
        s = model.stream(seed=1)
        x, y, made, out, raw = own.samples, heard.samples, 0, [], []
        for i in range(0, len(x), 160):
            at[0] = i
            if i >= lag:
                layer.hear(y[i - lag:i - lag + 160])
            layer.speech(x[i:i + 160])
            rv = np.asarray(s.push(x[i:i + 160]).rotvec).reshape(-1, 3)
            out.append(np.asarray(layer.apply(rv, made)).reshape(-1, 3))
            raw.append(rv)
            made += len(rv)
        return np.vstack(out), calls, np.vstack(raw)

    for lag in (0, 3200, 8000):
        batched, calls, _ = run(ListeningLayer, lag)
        first = sum(1 for w in when if w < 5 * 16000)
        arrival, each, _ = run(OnArrival, lag)
        np.testing.assert_array_equal(batched, arrival)
        assert len(calls) <= len(each)
        if lag == 0:  # heard on time: while the other speaks, up to ~0.5 s is analysed at once
            assert max(calls) > 5 * max(each) and len(calls) < 0.6 * len(each)
            # while this head speaks and the other is silent (its first 5 s), the silence heard is
            # analysed once its frames reach the heard time the frames use (0.3 s back): about every
            # 0.26 s, not at every push
            assert 10 <= first <= 25, first
    assert np.abs(run(ListeningLayer, 0)[0] - run(ListeningLayer, 8000)[0]).max() > 0  # lateness shows
    # the other speaking from its first sample, this head silent: the first second listens as well
    voice = Audio(heard.samples[int(5.5 * 16000):], 16000)
    quiet = Audio(np.zeros(len(voice.samples), np.float32), 16000)
    batched, _, raw = run(ListeningLayer, 0, own=quiet, heard=voice)
    arrival, _, _ = run(OnArrival, 0, own=quiet, heard=voice)
    np.testing.assert_array_equal(batched, arrival)
    assert np.abs(batched[:25] - raw[:25]).max() > 0


def test_a_stream_builds_its_listening_layer_when_it_first_hears():
    from headmotion.synthesis import open_stream, synthesize

    own, heard, _ = _conversation()
    off = synthesize(own, "stream", seed=2, hear=heard)[0]
    s = open_stream("stream", seed=2)
    x, y, parts, late = own.samples, heard.samples, [], 5 * 16000  # the first heard audio after 5 s
    for i in range(0, late, 320):
        parts.append(s.push(x[i:i + 320]).rotvec)
    assert s._listener is None  # nothing heard yet: no layer, the model's frames
    s.hear(y[:late])
    for i in range(late, len(x), 320):
        s.hear(y[i:i + 320])
        parts.append(s.push(x[i:i + 320]).rotvec)
    parts.append(s.flush().rotvec)
    np.testing.assert_array_equal(np.vstack(parts), off.rotvec)  # as if it had heard from the start


def test_listening_is_checked():
    from headmotion.synthesis import Controls

    with pytest.raises(ParameterError, match="listening"):
        Controls(listening=4)
    with pytest.raises(ParameterError, match="listening"):
        Controls(listening=True)


def test_synth_hear_on_the_command_line(tmp_path):
    from typer.testing import CliRunner

    from headmotion.cli.app import app
    from headmotion.io import load_motion
    from headmotion.synthesis import synthesize

    out = tmp_path / "listening.csv"
    r = CliRunner().invoke(app, ["synth", str(EXAMPLES / "short.wav"), "--hear", str(EXAMPLES / "speech_male.wav"),
                                 "-m", "stream", "-o", str(out)])
    assert r.exit_code == 0, r.output
    got = load_motion(out)
    want = synthesize(EXAMPLES / "short.wav", "stream", hear=EXAMPLES / "speech_male.wav")[0]
    assert got.duration == pytest.approx(want.duration, abs=0.05)   # the longer side's timeline
    np.testing.assert_allclose(got.rotvec, want.rotvec, atol=1e-5)
    r = CliRunner().invoke(app, ["synth", str(EXAMPLES / "short.wav"), "--hear", str(EXAMPLES / "speech_male.wav"),
                                 "--listening", "5", "-o", str(tmp_path / "x.csv")])
    assert r.exit_code != 0 and "--listening" in r.output + str(r.exception)
