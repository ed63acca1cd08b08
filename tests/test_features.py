"""Speech features: known answers, frame counts, registry, normaliser, CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest

from headmotion import features as F
from headmotion.align import n_frames as count_frames
from headmotion.errors import (FormatError, LengthMismatchError, NotFittedError, ParameterError)
from headmotion.features import lpc
from headmotion.features.frames import deltas, fit_length, frame_signal, moving_average, with_deltas
from headmotion.io.audio import load_audio, resample
from headmotion.types import Audio, FeatureTrack

SR = 16000
DIMS = {"f0e": 6, "mfcc": 39, "fbank": 27, "wav": 100, "lsp": 16, "lar": 16, "prosody": 2}


def tone(freq, *, sr=SR, dur=1.0, amp=0.5):
    t = np.arange(int(round(sr * dur))) / sr
    return Audio((amp * np.sin(2 * np.pi * freq * t)).astype(np.float32), sr)


@pytest.fixture(scope="module")
def speech(examples_dir):
    return load_audio(examples_dir / "speech" / "speech_male.wav")


# --------------------------------------------------------------------------- F0 and prosody

@pytest.mark.parametrize("freq", [120.0, 220.0])
def test_f0_of_tones_within_one_percent(freq):
    tr = F.extract("f0e", tone(freq, dur=1.5), voicing=True)
    assert tr.names == ("logf0", "energy", "d_logf0", "d_energy", "dd_logf0", "dd_energy", "voiced")
    f0 = np.exp(tr.values[10:-10, 0])
    np.testing.assert_allclose(f0, freq, rtol=0.01)
    assert tr.values[:, 6].mean() > 0.95
    # steady tone: energy of a 0.5-amplitude sine is 10 log10(0.125) dB; deltas vanish
    np.testing.assert_allclose(tr.values[20:-20, 1], 10 * np.log10(0.125), atol=0.05)
    np.testing.assert_allclose(tr.values[20:-20, 2:6], 0.0, atol=1e-3)


def test_f0e_is_six_dims_and_pitch_step():
    a = tone(150.0)
    assert F.extract("f0e", a).dim == 6
    np.testing.assert_allclose(np.exp(F.extract("f0e", a, pitch_step=0.01).values[10:-10, 0]), 150, rtol=0.01)


def test_prosody_pitch_in_semitones_and_hz():
    tr = F.extract("prosody", tone(220.0))
    assert tr.names == ("pitch", "loudness")
    np.testing.assert_allclose(tr.values[10:-10, 0], 12 * np.log2(220 / 27.5), atol=0.15)  # 36 st
    hz = F.extract("prosody", tone(220.0), unit="hz")
    np.testing.assert_allclose(hz.values[10:-10, 0], 220.0, rtol=0.01)
    # openSMILE cIntensity loudness: (I / 1e-6)^0.3, I = Hamming-weighted mean square = A²/2
    np.testing.assert_allclose(tr.values[20:-20, 1], (0.125 / 1e-6) ** 0.3, rtol=0.01)
    # both loudness variants grow with level by the power law (+20 dB -> ×10^0.6)
    for kind in ("intensity", "auditory"):
        quiet = F.extract("prosody", tone(220.0, amp=0.05), loudness=kind).values[20:-20, 1].mean()
        loud = F.extract("prosody", tone(220.0), loudness=kind).values[20:-20, 1].mean()
        assert loud / quiet == pytest.approx(10 ** 0.6, rel=0.01)
    with pytest.raises(ParameterError, match="unit"):
        F.extract("prosody", tone(220.0), unit="mel")


def test_f0e_on_speech_interpolates_unvoiced(examples_dir, speech):
    tr = F.extract("f0e", speech, voicing=True)
    voiced = tr.values[:, 6]
    assert 0.3 < voiced.mean() < 0.9
    f0 = np.exp(tr.values[:, 0])
    assert np.all((f0 > 60) & (f0 < 400))  # interpolated, no zeros
    female = F.extract("f0e", load_audio(examples_dir / "speech" / "speech_female.wav"))
    assert np.median(f0) < 150 < np.median(np.exp(female.values[:, 0]))
    # smoothing: the static streams change slowly (10-frame moving average)
    assert np.abs(np.diff(tr.values[:, 0])).max() < 0.2


# --------------------------------------------------------------------------- deltas, framing

def test_deltas_of_ramp_are_constant():
    x = np.stack([np.arange(30) * 0.5, -2.0 * np.arange(30)], 1)
    d = deltas(x)
    np.testing.assert_allclose(d, np.tile([0.5, -2.0], (30, 1)), atol=1e-12)
    v, names = with_deltas(x, ["a", "b"])
    assert names == ["a", "b", "d_a", "d_b", "dd_a", "dd_b"]
    np.testing.assert_allclose(v[:, 4:], 0.0, atol=1e-12)
    # a parabola has a constant second delta
    q = (np.arange(40.0) ** 2)[:, None]
    np.testing.assert_allclose(deltas(deltas(q))[4:-4], 2.0, atol=1e-9)
    assert deltas(np.ones((3, 2))).shape == (3, 2)


def test_moving_average_window():
    x = np.zeros((30, 1))
    x[15] = 10.0
    y = moving_average(x, 10)
    assert y.sum() == pytest.approx(10.0)
    assert np.count_nonzero(y) == 10 and y.max() == pytest.approx(1.0)


@pytest.mark.parametrize("fps", [25.0, 29.97, 100.0])
@pytest.mark.parametrize("name", sorted(DIMS))
def test_frame_counts_for_odd_lengths_and_rates(name, fps):
    rng = np.random.default_rng(0)
    a = Audio((0.1 * rng.standard_normal(16001)).astype(np.float32), SR)
    tr = F.extract(name, a, fps=fps)
    expected = {25.0: 25, 29.97: 30, 100.0: 100}[fps]
    assert count_frames(16001, SR, fps) == expected
    assert tr.values.shape == (expected, DIMS[name])
    assert tr.fps == fps and len(tr.names) == DIMS[name]
    assert F.extract(name, a, fps=fps, n_frames=expected + 7).n_frames == expected + 7
    assert F.extract(name, a, fps=fps, n_frames=3).n_frames == 3


def test_fit_length_and_frame_signal_centres():
    v = np.arange(6.0).reshape(3, 2)
    np.testing.assert_array_equal(fit_length(v, 5)[3:], [[4, 5], [4, 5]])
    np.testing.assert_array_equal(fit_length(v, 2), v[:2])
    x = np.arange(1, 101, dtype=float)
    fr = frame_signal(x, sample_rate=100, fps=10, n_frames=10, win_length=10)
    np.testing.assert_array_equal(fr[:, 0], np.arange(1, 101, 10))  # centre 5 -> start 0
    fr = frame_signal(x, sample_rate=100, fps=10, n_frames=10, win_length=20)
    assert fr[0, :5].tolist() == [0] * 5 and fr[0, 5] == 1  # zeros before the signal


def test_input_rate_does_not_matter():
    a16 = tone(200.0, sr=16000)
    a44 = Audio(resample(a16.samples, 16000, 44100), 44100)
    for name in ("mfcc", "fbank", "f0e"):
        v16, v44 = F.extract(name, a16).values, F.extract(name, a44).values
        assert v16.shape == v44.shape
        np.testing.assert_allclose(v16[5:-5, :3], v44[5:-5, :3], atol=0.05, rtol=0.01)


# --------------------------------------------------------------------------- spectral

def test_fbank_of_a_tone_peaks_in_the_right_band():
    from headmotion.features.spectral import _mel_bank

    for freq in (300.0, 1000.0, 3000.0):
        tr = F.extract("fbank", tone(freq))
        assert tr.names[-1] == "energy" and tr.dim == 27
        _, centres = _mel_bank(SR, 512, 26)
        expected = int(np.argmin(np.abs(centres - freq)))
        assert int(np.argmax(tr.values[50, :26])) == expected


def test_mel_bank_equals_librosa():
    librosa = pytest.importorskip("librosa")
    from headmotion.features.spectral import _mel_bank, a_weighting_db

    bank, _ = _mel_bank(16000, 512, 26)
    ref = librosa.filters.mel(sr=16000, n_fft=512, n_mels=26, htk=True, norm=None)
    np.testing.assert_allclose(bank, ref, atol=1e-6)
    f = np.array([50.0, 500.0, 1000.0, 6000.0])
    np.testing.assert_allclose(a_weighting_db(f), librosa.A_weighting(f), atol=1e-6)


def test_mfcc_energy_and_names():
    tr = F.extract("mfcc", tone(440.0, amp=0.5))
    assert tr.dim == 39 and tr.names[:2] == ("energy", "c1") and tr.names[13] == "d_energy"
    # raw energy of a 400-sample window of a 0.5-amplitude sine: 400 * 0.125
    np.testing.assert_allclose(tr.values[10:-10, 0], np.log(400 * 0.125), atol=0.01)
    static = F.extract("mfcc", tone(440.0), deltas=False)
    assert static.dim == 13


def test_wav_frames_reproduce_the_4khz_signal(speech):
    tr = F.extract("wav", speech)
    assert tr.dim == 100 and tr.names[0] == "s000"
    y = resample(speech.samples, speech.sample_rate, 4000)
    T = tr.n_frames
    middle = tr.values[:, 30:70].reshape(-1)  # frame t centred on sample 40 t + 20
    n = min(len(middle), len(y))
    np.testing.assert_array_equal(middle[:n], y[:n])
    np.testing.assert_array_equal(tr.values[0, :30], 0.0)
    assert T == count_frames(len(speech), speech.sample_rate, 100)


# --------------------------------------------------------------------------- LPC, LSP, LAR

def test_lsp_of_second_order_closed_form():
    a1, a2 = -0.9, 0.64  # poles at 0.8 e^{±j 0.97}
    w = lpc.lpc_to_lsf(np.array([1.0, a1, a2]))
    # P'(z) = 1 + (a1 + a2 - 1) z^-1 + z^-2, Q'(z) = 1 + (a1 - a2 + 1) z^-1 + z^-2
    wp = np.arccos(-(a1 + a2 - 1) / 2)
    wq = np.arccos(-(a1 - a2 + 1) / 2)
    np.testing.assert_allclose(w, sorted([wp, wq]), atol=1e-9)


def test_lsp_of_stable_polynomials_interleave_on_the_unit_circle():
    rng = np.random.default_rng(3)
    polys = []
    for _ in range(50):
        r = rng.uniform(0.3, 0.97, 6)
        th = rng.uniform(0.05, 3.0, 6)
        poles = np.concatenate([r * np.exp(1j * th), r * np.exp(-1j * th)])
        polys.append(np.real(np.poly(poles)))
    A = np.array(polys)  # order 12, stable
    lsf = lpc.lpc_to_lsf(A)
    assert lsf.shape == (50, 12)
    assert np.all(np.diff(lsf, axis=1) > 0) and np.all((lsf > 0) & (lsf < np.pi))
    for a, w in zip(A, lsf):
        P = np.append(a, 0) + np.append(0, a[::-1])
        Q = np.append(a, 0) - np.append(0, a[::-1])
        rp, rq = np.roots(P), np.roots(Q)
        np.testing.assert_allclose(np.abs(rp), 1.0, atol=1e-6)
        np.testing.assert_allclose(np.abs(rq), 1.0, atol=1e-6)
        up_p = np.sort(np.angle(rp[rp.imag > 1e-9]))
        up_q = np.sort(np.angle(rq[rq.imag > 1e-9]))
        np.testing.assert_allclose(w[0::2], up_p, atol=1e-8)  # P, Q, P, Q, …
        np.testing.assert_allclose(w[1::2], up_q, atol=1e-8)
    np.testing.assert_allclose(lpc.lsf_to_lpc(lsf), A, atol=1e-8)


def _step_up(k):
    a = np.array([1.0])
    for km in k:
        a = np.append(a, 0.0)
        a = a + km * a[::-1]
    return a


def test_lar_of_known_reflection_coefficients():
    k = np.array([0.5, -0.3, 0.2, 0.7, -0.6])
    a = _step_up(k)
    np.testing.assert_allclose(lpc.lpc_to_reflection(a), k, atol=1e-12)
    np.testing.assert_allclose(lpc.reflection_to_lar(lpc.lpc_to_reflection(a)),
                               np.log((1 + k) / (1 - k)), atol=1e-12)
    # Levinson on the autocorrelation of an AR(1) process r_k = phi^k gives k1 = -phi, rest 0
    phi = 0.6
    a, kk = lpc.levinson(phi ** np.arange(5)[None, :], 4)
    np.testing.assert_allclose(kk[0], [-phi, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(a[0], [1, -phi, 0, 0, 0], atol=1e-12)


def test_lpc_methods_agree_on_speech(speech):
    seg = Audio(speech.samples[16000:32000], SR)
    auto = lpc.lpc_frames(seg, fps=100, n_frames=100, order=12)
    burg = lpc.lpc_frames(seg, fps=100, n_frames=100, order=12, method="burg")
    la, lb = lpc.lpc_to_lsf(auto), lpc.lpc_to_lsf(burg)
    assert np.median(np.abs(la - lb)) < 0.05  # radians
    lar = F.extract("lar", speech)
    assert np.all(np.isfinite(lar.values)) and lar.names[0] == "lar01"


# --------------------------------------------------------------------------- registry, config

def test_registry_and_config_roundtrip(tmp_path):
    assert set(DIMS) <= set(F.available())
    cfg = F.FeatureConfig("f0e", fps=50, params={"voicing": True})
    d = json.loads(json.dumps(cfg.to_dict()))
    cfg2 = F.FeatureConfig.from_dict(d)
    assert cfg2 == cfg
    a = tone(180.0)
    np.testing.assert_array_equal(cfg.extract(a).values, cfg2.extract(a).values)
    assert cfg.extract(a, n_frames=60).n_frames == 60
    with pytest.raises(ParameterError, match="unknown keys"):
        F.FeatureConfig.from_dict({"name": "mfcc", "hop": 3})
    with pytest.raises(ParameterError, match="JSON"):
        F.FeatureConfig("mfcc", params={"x": object()})

    def energy(audio, *, fps, n_frames, scale=1.0):
        fr = frame_signal(audio.samples, sample_rate=audio.sample_rate, fps=fps, n_frames=n_frames,
                          win_length=160)
        return scale * np.sqrt(np.mean(fr ** 2, axis=1))

    F.register("rms", energy)
    try:
        assert "rms" in F.available()
        tr = F.extract("rms", tone(200.0), scale=2.0)  # 160 samples = two whole periods
        assert tr.names == ("rms_0",) and tr.values[50, 0] == pytest.approx(2 * 0.5 / np.sqrt(2), rel=1e-3)
        with pytest.raises(ParameterError, match="already registered"):
            F.register("rms", energy)
        with pytest.raises(ParameterError, match="no parameter 'bogus'"):
            F.extract("rms", a, bogus=1)
    finally:
        F.unregister("rms")
    with pytest.raises(ParameterError, match="built-in"):
        F.register("mfcc", energy)
    with pytest.raises(ParameterError, match="unknown feature set 'nope'.*mfcc"):
        F.extract("nope", a)
    with pytest.raises(ParameterError, match="fps"):
        F.extract("mfcc", a, fps=0)
    with pytest.raises(ParameterError, match="n_frames"):
        F.extract("mfcc", a, n_frames=-1)


def test_register_file_npz_and_csv(tmp_path):
    a = tone(150.0, dur=2.0)
    t = np.arange(400) / 200.0  # frame t at time t / fps, as every track in headmotion (align.py)
    ema = np.stack([np.sin(2 * np.pi * t), t], 1)  # 200 fps, 2 s
    np.savez(tmp_path / "ema.npz", values=ema, fps=200.0, names=np.array(["tongue", "lip"]))
    F.register_file("ema", tmp_path / "ema.npz")
    try:
        tr = F.extract("ema", a, fps=100)
        assert tr.names == ("tongue", "lip") and tr.n_frames == 200 and tr.fps == 100
        tc = np.arange(200) / 100
        np.testing.assert_allclose(tr.values[1:-1, 1], tc[1:-1], atol=1e-5)
        # a csv with a time column for another recording
        with open(tmp_path / "other.csv", "w") as fh:
            fh.write("time,jaw\n")
            for ti in np.arange(0, 2.0, 0.01):
                fh.write(f"{ti:.4f},{3 * ti:.6f}\n")  # times at frame starts: interpolated
        other = F.extract("ema", a, fps=50, path=tmp_path / "other.csv")
        assert other.names == ("jaw",) and other.n_frames == 100
        np.testing.assert_allclose(other.values[1:-1, 0], 3 * (np.arange(100) / 50)[1:-1], atol=1e-4)
        with pytest.raises(LengthMismatchError, match="feature file lasts 2.000 s"):
            F.extract("ema", tone(150.0, dur=3.0))
    finally:
        F.unregister("ema")
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n3\n")
    with pytest.raises(FormatError, match="line 3"):
        F.register_file("bad", tmp_path / "bad.csv", file_fps=100)
    assert "bad" not in F.available()


# --------------------------------------------------------------------------- normaliser

def test_normalizer(rng):
    xs = [rng.normal(3.0, 2.0, (500, 4)), rng.normal(3.0, 2.0, (300, 4))]
    xs[0][:, 3] = 7.0
    xs[1][:, 3] = 7.0  # a constant dimension
    norm = F.Normalizer().fit(xs)
    z = norm.transform(np.vstack(xs))
    np.testing.assert_allclose(z[:, :3].mean(0), 0, atol=1e-12)
    np.testing.assert_allclose(z[:, :3].std(0), 1, atol=1e-12)
    np.testing.assert_allclose(z[:, 3], 0)
    np.testing.assert_allclose(norm.inverse_transform(z), np.vstack(xs), atol=1e-12)
    arrays = norm.to_arrays("x")
    assert set(arrays) == {"x_mean", "x_std"} and set(norm.to_arrays("m_")) == {"m_mean", "m_std"}
    back = F.Normalizer.from_arrays(arrays, "x")
    np.testing.assert_allclose(back.transform(xs[0]), norm.transform(xs[0]))
    tr = FeatureTrack(xs[1], 100, tuple("abcd"))
    out = norm.transform(tr)
    assert isinstance(out, FeatureTrack) and out.names == tr.names
    with pytest.raises(NotFittedError):
        F.Normalizer().transform(xs[0])
    with pytest.raises(ParameterError, match="fitted on 4 dims"):
        norm.transform(np.zeros((3, 5)))
    var_only = F.Normalizer(with_mean=False).fit(xs)
    assert np.allclose(var_only.mean_, 0)


# --------------------------------------------------------------------------- real files, CLI

@pytest.mark.shared
@pytest.mark.parametrize("name", ["jfk.flac", "00083.wav", "chinese_news.wav"])
def test_all_features_finite_on_real_speech(shared_data, name):
    a = load_audio(shared_data / "speech" / name)
    n = count_frames(len(a), a.sample_rate, 100)
    for fs in DIMS:
        tr = F.extract(fs, a)
        assert tr.values.shape == (n, DIMS[fs]) and np.all(np.isfinite(tr.values))


def test_cli_features(tmp_path, examples_dir):
    from headmotion.cli import main

    wav = examples_dir / "speech" / "short.wav"
    out = tmp_path / "f.npz"
    assert main(["features", str(wav), "--set", "mfcc", "-o", str(out)]) == 0
    with np.load(out) as z:
        assert z["values"].shape[1] == 39 and float(z["fps"]) == 100.0
        assert list(z["names"][:2]) == ["energy", "c1"]
        assert json.loads(str(z["config"]))["feature"]["name"] == "mfcc"
    csv = tmp_path / "f.csv"
    assert main(["features", str(wav), "--set", "f0e", "--fps", "25", "-p", "voicing=true",
                 "-o", str(csv)]) == 0
    from headmotion.features.external import load_feature_file

    back = load_feature_file(csv)
    assert back.fps == 25 and back.names[-1] == "voiced" and back.dim == 7
    bad = tmp_path / "bad.npz"
    assert main(["features", str(tmp_path / "missing.wav"), "-o", str(bad)]) != 0
    assert main(["features", str(wav), "--set", "nope", "-o", str(bad)]) != 0
    assert not bad.exists() and not list(tmp_path.glob(".*part*"))
