"""DNN inference in numpy (models/numpy_nets.py): the same motion as PyTorch's layers (≤ 1e-6 rad)
for an mfcc-dnn model with the system's own settings and for small freshly trained models of every
DNN system, saved and loaded; a model gives the same motion before and after saving; loading and
synthesising (a DNN model or the shipped default) imports no torch."""

from __future__ import annotations

import contextlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from headmotion.models import numpy_nets

DEFAULT_MODEL = Path(__file__).resolve().parents[1] / "src/headmotion/data/default_model.hmz"
#: numpy vs torch float32 layers, after the whole post chain (radians)
TOL = 1e-6
REAL_SPEECH = ["jfk.flac", "chinese_news.wav", "RD_Radio34_002.wav"]


@contextlib.contextmanager
def torch_layers():
    """Run the networks' dense layers and activations with PyTorch's kernels (``F.linear``,
    ``torch.relu`` / ``tanh`` / ``sigmoid``: what ``nn.Linear`` and the activation modules call)
    instead of numpy's — the torch forward pass, everything else unchanged."""
    torch = pytest.importorskip("torch")
    F = torch.nn.functional

    def t(x):
        return torch.from_numpy(np.ascontiguousarray(x, dtype=np.float32))

    keep_linear, keep_act = numpy_nets.linear, dict(numpy_nets.ACTIVATIONS)
    numpy_nets.linear = lambda x, w, b: F.linear(t(x), t(w), t(b)).numpy()
    numpy_nets.ACTIVATIONS.update(relu=lambda x: torch.relu(t(x)).numpy(), tanh=lambda x: torch.tanh(t(x)).numpy(),
                                  sigmoid=lambda x: torch.sigmoid(t(x)).numpy())
    try:
        with torch.no_grad():
            yield
    finally:
        numpy_nets.linear = keep_linear
        numpy_nets.ACTIVATIONS.clear()
        numpy_nets.ACTIVATIONS.update(keep_act)


def _both(model, audio, seed=0):
    got = model.predict(audio, seed=seed).rotvec
    with torch_layers():
        ref = model.predict(audio, seed=seed).rotvec
    return got, ref


@pytest.fixture(scope="module")
def full_dnn(tmp_path_factory):
    """An mfcc-dnn model with the system's own settings (full-size networks, the whole post chain),
    trained briefly, saved and loaded: as a shipped or user's model file is used."""
    pytest.importorskip("torch")
    import torch

    from headmotion.systems import create, load_model
    from test_cccae import envelope_corpus

    corpus = envelope_corpus(n_recordings=3, seconds=10.0, fps=25.0, seed=4, splits=["train", "train", "valid"])
    with torch.random.fork_rng(devices=[]):
        torch.set_num_threads(1)
        m = create("mfcc-dnn", max_epochs=2, patience=2, n_threads=1).fit(corpus)
    return load_model(m.save(tmp_path_factory.mktemp("dnn") / "mfcc.hmz"))


def test_full_dnn_model_matches_torch_layers_on_bundled_speech(full_dnn, examples_dir):
    from headmotion.io import load_audio

    assert isinstance(full_dnn.regressor_, numpy_nets.Regressor)   # loaded as arrays, not torch modules
    for name in ("speech_male.wav", "speech_female.wav"):
        got, ref = _both(full_dnn, load_audio(examples_dir / "speech" / name))
        assert got.shape == ref.shape and len(got) > 500
        assert np.abs(got - ref).max() <= TOL, name
        assert np.abs(got).max() > 0.02                       # the head moves


@pytest.mark.parametrize("name", REAL_SPEECH)
def test_full_dnn_model_matches_torch_layers_on_real_speech(full_dnn, shared_data, name):
    from headmotion.io import load_audio

    path = shared_data / "speech" / name
    if not path.exists():
        pytest.skip(f"{path} is not in ../shared")
    got, ref = _both(full_dnn, load_audio(path))
    assert np.abs(got - ref).max() <= TOL


@pytest.mark.parametrize("which", ["default", "dnn"])
def test_loading_and_synthesising_imports_no_torch(full_dnn, examples_dir, which, tmp_path):
    """The shipped default, and a saved DNN model, load and synthesise without importing torch."""
    path = DEFAULT_MODEL if which == "default" else full_dnn.save(tmp_path / "dnn.hmz")
    code = ("import sys\nfrom headmotion.systems import load_model\nfrom headmotion.io import load_audio\n"
            f"m = load_model({str(path)!r})\n"
            f"r = m.predict(load_audio({str(examples_dir / 'speech' / 'short.wav')!r})).rotvec\n"
            "assert len(r) > 10\nprint('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "False"


SMALL = dict(regressor_hidden=(32,), postfilter_hidden=(32,), postfilter_code=8, max_epochs=1, patience=3,
             batch_size=256, n_threads=1, context=5, segment=20, cross_fit=False)
EMBED = dict(ae_hidden=(32,), embedding_dim=8, ae_max_epochs=1, pretrain_epochs=1)
SYSTEMS = {"cccae": EMBED, "ae-dnn": EMBED, "mfcc-dnn": {}, "fbank-dnn": {}, "f0e-dnn": {}, "wav-dnn": {}}


@pytest.fixture(scope="module")
def corpus():
    pytest.importorskip("torch")
    from test_cccae import envelope_corpus

    return envelope_corpus(n_recordings=2, seconds=8.0, fps=25.0, seed=3, splits=["train", "valid"])


@pytest.mark.parametrize("system", sorted(SYSTEMS))
def test_trained_model_saved_and_loaded_matches_torch_layers(corpus, system, tmp_path):
    import torch

    from headmotion.systems import create, load_model

    with torch.random.fork_rng(devices=[]):
        torch.set_num_threads(1)
        m = create(system, **SMALL, **SYSTEMS[system]).fit(corpus)
    audio = corpus[1].audio
    in_memory = m.predict(audio, seed=1).rotvec
    path = m.save(tmp_path / f"{system}.hmz")
    loaded = load_model(path)
    assert isinstance(loaded.regressor_, numpy_nets.Regressor)
    got, ref = _both(loaded, audio, seed=1)
    np.testing.assert_array_equal(got, in_memory)            # the same motion before and after saving
    assert np.abs(got - ref).max() <= TOL
    assert np.abs(got).max() > 0
    # saving the loaded model writes the same networks back
    again = load_model(loaded.save(tmp_path / "again.hmz"))
    np.testing.assert_array_equal(again.predict(audio, seed=1).rotvec, got)
    if system == "mfcc-dnn":  # the stream runs the same numpy layers
        st = loaded.stream(seed=1)
        x = np.asarray(audio.samples, dtype=np.float32)
        parts = [st.push(x[i:i + 1600]).rotvec for i in range(0, len(x), 1600)] + [st.flush().rotvec]
        assert np.abs(np.concatenate(parts) - got).max() <= TOL


def test_loading_rejects_arrays_of_the_wrong_shape():
    arrays = {"net.0.weight": np.zeros((4, 33), np.float32), "net.0.bias": np.zeros(4, np.float32),
              "net.3.weight": np.zeros((3, 4), np.float32), "net.3.bias": np.zeros(3, np.float32)}
    net = numpy_nets.regressor_from_arrays(arrays, "", in_dim=3, context=5, hidden=(4,), dropout=0.1)
    assert (net.in_dim, net.context, net.out_dim) == (3, 5, 3)
    with pytest.raises(ValueError, match=r"net.0.weight has shape \(4, 33\), expected \(4, 44\)"):
        numpy_nets.regressor_from_arrays(arrays, "", in_dim=4, context=5, hidden=(4,), dropout=0.1)
    with pytest.raises(KeyError):
        numpy_nets.regressor_from_arrays(arrays, "", in_dim=3, context=5, hidden=(4,), dropout=0.0)


def test_layers_compute_what_the_torch_modules_do():
    torch = pytest.importorskip("torch")
    from headmotion.models import nets

    torch.manual_seed(0)
    ae = nets.StackedAutoencoder(12, hidden=(16,), code_dim=4, activation="tanh").eval()
    reg = nets.ContextRegressor(4, context=2, hidden=(8, 8), dropout=0.1).eval()
    x = np.random.default_rng(0).standard_normal((40, 12)).astype(np.float32)
    with torch.no_grad():
        z_t = ae.encode(torch.from_numpy(x)).numpy()
        rec_t = ae(torch.from_numpy(x)).numpy()
        w = torch.from_numpy(np.ascontiguousarray(z_t[:20].reshape(4, 20)))
        y_t = reg(w).numpy()
    np.testing.assert_allclose(numpy_nets.encode(ae, x), z_t, atol=1e-6)
    np.testing.assert_allclose(numpy_nets.as_numpy(ae)(x), rec_t, atol=1e-6)
    np.testing.assert_allclose(numpy_nets.as_numpy(reg)(z_t[:20].reshape(4, 20)), y_t, atol=1e-6)
    back = numpy_nets.state_arrays(numpy_nets.as_numpy(reg), "r/")
    assert set(back) == {f"r/{k}" for k in reg.state_dict()}
