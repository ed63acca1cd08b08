"""Long inputs in bounded memory: block reading equals whole-file reading, and a
causal model synthesises a file block by block with the frames of its offline output."""

import numpy as np
import pytest
import soundfile as sf

from conftest import OLD_DNN_MODEL, OLD_TWS_MODEL
from headmotion.cli.synth_cmds import default_model_path, default_stream_model_path
from headmotion.errors import AudioLoadingError
from headmotion.io import load_audio
from headmotion.io.audio_blocks import audio_duration, iter_audio_blocks
from headmotion.systems import load_model
from headmotion.systems.long_input import predict_file_in_blocks


def _tone_file(path, sr, seconds, channels=1):
    t = np.arange(int(sr * seconds)) / sr
    x = 0.3 * np.sin(2 * np.pi * 220 * t) * (1 + 0.5 * np.sin(2 * np.pi * 0.7 * t))
    sf.write(path, np.tile(x[:, None], (1, channels)) if channels > 1 else x, sr)
    return x


def test_blocks_equal_the_whole_file_and_resample_like_load_audio(tmp_path):
    p = tmp_path / "a.wav"
    _tone_file(p, 16000, 7.3)
    whole = load_audio(p).samples
    blocks = list(iter_audio_blocks(p, sample_rate=16000, block_seconds=1.0))
    assert len(blocks) >= 7
    np.testing.assert_allclose(np.concatenate(blocks), whole, atol=1e-6)
    q = tmp_path / "b.wav"
    _tone_file(q, 44100, 5.0, channels=2)
    ref = load_audio(q, sample_rate=16000).samples
    got = np.concatenate(list(iter_audio_blocks(q, sample_rate=16000, block_seconds=0.5)))
    assert abs(len(got) - len(ref)) <= 2
    n = min(len(got), len(ref))
    assert np.max(np.abs(got[:n] - ref[:n])) < 1e-3
    assert audio_duration(q) == pytest.approx(5.0)


def test_block_reader_errors_name_the_file(tmp_path):
    with pytest.raises(AudioLoadingError, match="nope.wav"):
        list(iter_audio_blocks(tmp_path / "nope.wav", sample_rate=16000))
    bad = tmp_path / "bad.wav"
    bad.write_bytes(b"RIFF\x00\x00garbage" * 10)
    with pytest.raises(AudioLoadingError, match="bad.wav"):
        list(iter_audio_blocks(bad, sample_rate=16000))


@pytest.mark.parametrize("path", [default_stream_model_path, default_model_path, lambda: OLD_TWS_MODEL,
                                  lambda: OLD_DNN_MODEL], ids=["stream", "default", "tws-hier", "mfcc-dnn"])
def test_model_block_by_block_equals_its_stream(examples_dir, path):
    m = load_model(path())
    wav = examples_dir / "speech" / "speech_male.wav"
    a = predict_file_in_blocks(m, wav, seed=2, block_seconds=1.0)
    st = m.stream(seed=2)
    x = load_audio(wav, sample_rate=m.sample_rate).samples
    parts = [st.push(x[i:i + 1234]).rotvec for i in range(0, len(x), 1234)] + [st.flush().rotvec]
    b = np.vstack([p for p in parts if len(p)])
    assert len(a) == len(b) > 100 and a.fps == m.frame_rate
    # a causal system gives the same frames for any chunking; a DNN stream's network sees other
    # batch sizes for other chunkings, and float32 matrix products round differently per batch
    # size: the DNN stream contract's 1e-6 rad (systems/dnn_stream.py)
    np.testing.assert_allclose(a.rotvec, b, atol=1e-6 if m.name.endswith("dnn") else 1e-9)
