"""The network systems' GPU path, tested on the CPU (the same code with ``device="cpu"``).

Known answers: a GPU draws the training randomness the CPU draws (the regressor's dropout masks
from the CPU generator, :class:`headmotion.models.nets.HostDropout`; motion-flow's noise from a
CPU generator), so a model trained with the device path's dropout is the CPU model bit for bit;
float32 stays full float32 (no TF32) during training and the caller's settings come back."""

from __future__ import annotations

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from headmotion.models import nets  # noqa: E402
from headmotion.systems import create  # noqa: E402

pytestmark = pytest.mark.usefixtures("torch_one_thread")

TINY = {"max_epochs": 2, "patience": 2, "ae_max_epochs": 2, "pretrain_epochs": 1, "n_threads": 1,
        "ae_hidden": (32,), "embedding_dim": 8, "regressor_hidden": (32, 32), "context": 5,
        "postfilter_hidden": (32,), "postfilter_code": 8, "cross_fit": False}


@pytest.mark.parametrize("shape", [(256, 256), (1000, 64), (7, 3)])
def test_host_dropout_mask_is_the_cpu_dropout(shape):
    x = torch.randn(shape, requires_grad=True)
    torch.manual_seed(5)
    want = torch.nn.functional.dropout(x, 0.1, True)
    after_cpu = torch.random.get_rng_state()
    torch.manual_seed(5)
    got = nets.HostDropout(0.1).train().masked(x)
    assert torch.equal(got, want)
    assert torch.equal(torch.random.get_rng_state(), after_cpu)  # the generator moves as on the CPU
    assert nets.HostDropout(0.1).eval()(x) is x


def test_the_device_paths_dropout_trains_the_cpu_model(planted, monkeypatch):
    """cccae with the dropout a GPU runs (masks drawn on the CPU, then multiplied) is the CPU model
    bit for bit: nothing in its training randomness depends on the device."""
    corpus = planted(minutes=1.0, n_recordings=3, speakers=("a",), seed=2)
    cpu = create("cccae", **TINY).fit(corpus)
    monkeypatch.setattr(nets.HostDropout, "forward",
                        lambda self, x: self.masked(x) if self.training and self.p else x)
    device_path = create("cccae", **TINY).fit(corpus)
    audio = corpus[0].audio
    np.testing.assert_array_equal(cpu.predict(audio, seed=0).rotvec, device_path.predict(audio, seed=0).rotvec)
    assert cpu.history_["regressor"]["valid"] == device_path.history_["regressor"]["valid"]


def test_regressor_dropout_is_host_dropout():
    net = nets.ContextRegressor(4, context=2, hidden=(8, 8), dropout=0.1)
    assert sum(isinstance(m, nets.HostDropout) for m in net.modules()) == 2


def test_exact_float32_turns_tf32_off_and_restores_the_callers_settings():
    b = torch.backends
    prev = (b.cuda.matmul.allow_tf32, b.cudnn.allow_tf32, torch.get_float32_matmul_precision())
    b.cudnn.allow_tf32 = True
    torch.set_float32_matmul_precision("medium")
    try:
        with nets.exact_float32():
            assert not b.cudnn.allow_tf32 and not b.cuda.matmul.allow_tf32
            assert torch.get_float32_matmul_precision() == "highest"
        assert b.cudnn.allow_tf32 and torch.get_float32_matmul_precision() == "medium"
    finally:
        b.cuda.matmul.allow_tf32, b.cudnn.allow_tf32 = prev[0], prev[1]
        torch.set_float32_matmul_precision(prev[2])


def test_flow_noise_is_drawn_where_the_generator_lives():
    from headmotion.models.flow_net import FlowNet, flow_loss

    net = FlowNet(4, hidden=8, n_blocks=1)
    x1 = torch.randn(2, 3, 16)
    args = (torch.randn(2, 4, 16), torch.ones(2), torch.zeros(2, 1, 16), torch.ones(2, 1, 16))
    a = flow_loss(net, x1, *args, generator=torch.Generator().manual_seed(3))
    b = flow_loss(net, x1, *args, generator=torch.Generator().manual_seed(3))
    c = flow_loss(net, x1, *args, generator=torch.Generator().manual_seed(4))
    assert a.item() == b.item() != c.item()
