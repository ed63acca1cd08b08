"""Audio input/output: real third-party files, our own examples, bad input."""

from __future__ import annotations

import math
import numpy as np
import pytest
import soundfile as sf

from headmotion.errors import AudioLoadingError, ParameterError
from headmotion.io import audio as audio_mod
from headmotion.io.audio import audio_info, load_audio, resample, save_audio
from headmotion.types import Audio

SPEECH_FILES = ["00083.wav", "2_scott_0_103_103_28s.wav", "RD_Radio31_000.wav", "RD_Radio34_002.wav",
                "audio3_20sec.wav", "chinese_news.wav", "japanese.wav", "jfk.flac",
                "video_retalking_1.wav"]


def _tone(freq=440.0, sr=16000, dur=1.0, amp=0.5):
    t = np.arange(int(sr * dur)) / sr
    return (amp * np.sin(2 * np.pi * freq * t)).astype(np.float32)


def _pyav_duration(path) -> float:
    import av

    with av.open(str(path)) as c:
        st = c.streams.audio[0]
        if st.duration is not None:
            return float(st.duration * st.time_base)
        return c.duration / 1e6


# --------------------------------------------------------------------------- real files

@pytest.mark.shared
@pytest.mark.parametrize("name", SPEECH_FILES)
def test_every_shared_speech_file_loads(shared_data, name):
    path = shared_data / "speech" / name
    if not path.exists():
        pytest.skip(f"{path} absent")
    a = load_audio(path)
    info = sf.info(str(path))
    assert a.samples.dtype == np.float32 and a.samples.ndim == 1
    assert a.sample_rate == info.samplerate
    # PCM/float/FLAC: exact frame count; MP3 (encoder delay/padding): within 60 ms
    tol = 0.06 if "MPEG" in info.subtype or "MP3" in info.format else 1e-9
    assert abs(a.duration - info.duration) <= tol
    assert np.all(np.isfinite(a.samples)) and 0.001 < np.abs(a.samples).max() <= 1.0


@pytest.mark.shared
def test_jfk_flac_24bit_stereo_downmix_and_resample(shared_data):
    path = shared_data / "speech" / "jfk.flac"
    info = sf.info(str(path))
    assert (info.channels, info.subtype, info.samplerate) == (2, "PCM_24", 44100)
    stereo, sr = sf.read(str(path), dtype="float32", always_2d=True)
    a = load_audio(path)
    np.testing.assert_allclose(a.samples, stereo.mean(axis=1), atol=1e-6)
    b = load_audio(path, sample_rate=16000)
    assert b.sample_rate == 16000
    assert abs(len(b) - round(len(a) * 16000 / 44100)) <= 1
    # the resampled signal keeps its level
    assert abs(np.std(b.samples) / np.std(a.samples) - 1) < 0.02


@pytest.mark.shared
def test_float_wav(shared_data):
    path = shared_data / "speech" / "00083.wav"
    assert sf.info(str(path)).subtype == "FLOAT"
    a = load_audio(path)
    ref, _ = sf.read(str(path), dtype="float32")
    np.testing.assert_array_equal(a.samples, ref if ref.ndim == 1 else ref.mean(axis=1))


@pytest.mark.shared
def test_mp3_content_in_wav_is_decoded_by_pyav(shared_data, monkeypatch):
    path = shared_data / "speech" / "2_scott_0_103_103_28s.wav"
    info = sf.info(str(path))
    assert "MP3" in info.format or "MPEG" in info.subtype
    # PyAV alone decodes it
    data, sr, ch = audio_mod._read_pyav(path)
    assert (sr, ch) == (44100, 2)
    assert abs(len(data) / sr - _pyav_duration(path)) < 0.06
    # and load_audio falls back to PyAV when soundfile cannot read it (older libsndfile)
    def fail(p):
        raise RuntimeError("Format not recognised")

    monkeypatch.setattr(audio_mod, "_read_soundfile", fail)
    a = load_audio(path)
    assert a.sample_rate == 44100
    assert abs(a.duration - info.duration) < 0.06
    np.testing.assert_allclose(a.samples, data.mean(axis=1), atol=1e-6)


@pytest.mark.shared
def test_grid_mpg_audio_tracks(shared_data):
    files = sorted((shared_data / "talking_video" / "grid").glob("*.mpg"))
    if not files:
        pytest.skip("no GRID videos")
    for path in files:
        a = load_audio(path)
        d = audio_info(path)
        assert d["decoder"] == "PyAV"
        assert a.sample_rate == d["sample_rate"]
        # the MPEG-1 audio decoder adds up to one frame (1152 samples) of padding
        assert abs(a.duration - _pyav_duration(path)) < 0.05, path.name
        assert np.abs(a.samples).max() > 0.01


@pytest.mark.shared
def test_sadtalker_mp4_audio(shared_data):
    files = sorted((shared_data / "talking_video" / "sadtalker").glob("*.mp4"))
    if not files:
        pytest.skip("no sadtalker videos")
    path = files[0]
    a = load_audio(path, sample_rate=16000)
    assert a.sample_rate == 16000
    assert abs(a.duration - _pyav_duration(path)) < 0.05


# --------------------------------------------------------------------------- own examples

def test_bundled_examples_load(examples_dir):
    files = sorted((examples_dir / "speech").glob("*.wav"))
    assert len(files) >= 3
    total = 0.0
    for path in files:
        assert path.stat().st_size < 1_000_000
        a = load_audio(path)
        assert a.sample_rate == 16000 and sf.info(str(path)).channels == 1
        total += a.duration
    assert 10 <= total <= 30


# --------------------------------------------------------------------------- made here

def test_save_load_roundtrip_pcm16(tmp_path):
    x = _tone(220.0)
    p = tmp_path / "t.wav"
    save_audio(Audio(x, 16000), p)
    assert sf.info(str(p)).subtype == "PCM_16"
    a = load_audio(p)
    assert a.sample_rate == 16000 and len(a) == len(x)
    np.testing.assert_allclose(a.samples, x, atol=1.0 / 32768 + 1e-7)
    save_audio(Audio(x, 16000), tmp_path / "t.flac")
    np.testing.assert_allclose(load_audio(tmp_path / "t.flac").samples, x, atol=1.0 / 32768 + 1e-7)
    assert list(tmp_path.glob(".*part*")) == []


def test_save_audio_clips_and_rejects_unknown_extension(tmp_path):
    save_audio(Audio(np.array([2.0, -2.0, 0.5], np.float32), 8000), tmp_path / "c.wav")
    np.testing.assert_allclose(load_audio(tmp_path / "c.wav").samples, [1.0, -1.0, 0.5], atol=1e-4)
    with pytest.raises(ParameterError, match="extension"):
        save_audio(Audio(np.zeros(10, np.float32), 8000), tmp_path / "x.xyz")
    assert not (tmp_path / "x.xyz").exists()


def test_stereo_is_averaged(tmp_path):
    left, right = _tone(300.0), _tone(500.0, amp=0.2)
    sf.write(str(tmp_path / "s.wav"), np.stack([left, right], 1), 16000, subtype="FLOAT")
    a = load_audio(tmp_path / "s.wav")
    np.testing.assert_allclose(a.samples, (left + right) / 2, atol=1e-7)


def test_resample_keeps_frequency_and_length():
    x = _tone(1000.0, sr=16000, dur=1.0)
    y = resample(x, 16000, 8000)
    assert len(y) == 8000
    spec = np.abs(np.fft.rfft(y * np.hanning(len(y))))
    assert abs(np.argmax(spec) * 8000 / len(y) - 1000.0) <= 1.0
    with pytest.raises(ParameterError):
        load_audio("whatever.wav", sample_rate=0)


def test_mp3_and_video_containers_made_with_pyav(tmp_path):
    import av

    sr = 16000
    x = _tone(440.0, sr=sr, dur=1.0, amp=0.3)
    # an MP3 file, and the same bytes named .wav
    mp3 = tmp_path / "tone.mp3"
    with av.open(str(mp3), "w") as c:
        st = c.add_stream("libmp3lame", rate=sr, layout="mono")
        frame = av.AudioFrame.from_ndarray(x[None, :], format="fltp", layout="mono")
        frame.sample_rate = sr
        for pkt in st.encode(frame):
            c.mux(pkt)
        for pkt in st.encode(None):
            c.mux(pkt)
    a = load_audio(mp3)
    assert a.sample_rate == sr and abs(a.duration - 1.0) < 0.1
    fake = tmp_path / "mp3inside.wav"
    fake.write_bytes(mp3.read_bytes())
    b = load_audio(fake)
    assert b.sample_rate == sr and abs(b.duration - 1.0) < 0.1
    # a video without an audio track
    vid = tmp_path / "silent.mp4"
    with av.open(str(vid), "w") as c:
        st = c.add_stream("mpeg4", rate=10)
        st.width, st.height, st.pix_fmt = 32, 32, "yuv420p"
        for i in range(5):
            img = np.full((32, 32, 3), i * 40, np.uint8)
            for pkt in st.encode(av.VideoFrame.from_ndarray(img, format="rgb24")):
                c.mux(pkt)
        for pkt in st.encode(None):
            c.mux(pkt)
    with pytest.raises(AudioLoadingError, match="no audio track"):
        load_audio(vid)


# --------------------------------------------------------------------------- bad input

def test_missing_file(tmp_path):
    with pytest.raises(AudioLoadingError, match=r"nope\.wav.*not found"):
        load_audio(tmp_path / "nope.wav")


def test_empty_file(tmp_path):
    p = tmp_path / "empty.wav"
    p.write_bytes(b"")
    with pytest.raises(AudioLoadingError, match=r"empty\.wav.*empty file"):
        load_audio(p)


def test_truncated_wav(tmp_path):
    p = tmp_path / "full.wav"
    save_audio(Audio(_tone(), 16000), p)
    cut = tmp_path / "cut.wav"
    cut.write_bytes(p.read_bytes()[:5000])
    with pytest.raises(AudioLoadingError, match=r"cut\.wav.*truncated"):
        load_audio(cut)


def test_non_audio_bytes_named_wav(tmp_path):
    p = tmp_path / "text.wav"
    p.write_bytes(b"this is not audio at all, just some text\n" * 20)
    with pytest.raises(AudioLoadingError, match=r"text\.wav.*not a readable audio"):
        load_audio(p)


def test_zero_length_audio(tmp_path):
    p = tmp_path / "zero.wav"
    sf.write(str(p), np.zeros(0, np.float32), 16000, subtype="PCM_16")
    with pytest.raises(AudioLoadingError, match=r"zero\.wav.*zero-length"):
        load_audio(p)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nan_inf_samples(tmp_path, bad):
    x = _tone()
    x[100] = bad
    p = tmp_path / "bad.wav"
    sf.write(str(p), x, 16000, subtype="FLOAT")
    with pytest.raises(AudioLoadingError, match=r"bad\.wav.*NaN or inf"):
        load_audio(p)


def test_audio_info_reports_channels(tmp_path):
    p = tmp_path / "st.wav"
    sf.write(str(p), np.zeros((1600, 2), np.float32), 16000)
    d = audio_info(p)
    assert d["channels"] == 2 and d["sample_rate"] == 16000 and math.isclose(d["duration"], 0.1)


@pytest.mark.shared
def test_real_video_without_audio_track(shared_data):
    files = sorted((shared_data / "talking_video" / "styletalk").glob("*.mp4"))
    if not files:
        pytest.skip("no styletalk videos")
    with pytest.raises(AudioLoadingError, match=r"KristiNoem\.mp4|\.mp4: the file has no audio track"):
        load_audio(files[0])
