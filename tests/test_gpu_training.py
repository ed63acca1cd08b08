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


# -- the large-batch path (batch_scale), tested on the CPU -----------------------------------------
def test_speed_defaults_change_nothing_and_scaling_warms_up():
    from headmotion.models.train_speed import WARMUP_STEPS, Speed, WarmAdam

    net = torch.nn.Linear(3, 2)
    assert type(Speed().adam(net.parameters(), 1e-3)) is torch.optim.Adam
    sp = Speed("cpu", batch_scale=4, precision="bf16", compile_networks=True)
    assert sp.batch(256) == 1024 and sp.lr(2e-4) == pytest.approx(8e-4)
    assert sp.forward(net) is net  # compiled on a GPU only
    assert sp.describe() == {"batch_scale": 4, "precision": "float32", "compiled": False, "fused_adam": False}
    with sp.autocast():  # bf16 on a GPU only: the CPU stays float32
        assert net(torch.randn(2, 3)).dtype == torch.float32
    opt = sp.adam(net.parameters(), 2e-4)
    assert isinstance(opt, WarmAdam)
    lrs = []
    for _ in range(WARMUP_STEPS + 2):
        net(torch.randn(2, 3)).sum().backward()
        opt.step()
        lrs.append(opt.opt.param_groups[0]["lr"])
        opt.zero_grad()
    assert lrs[0] == pytest.approx(2e-4 + 6e-4 / WARMUP_STEPS) and lrs[-1] == pytest.approx(8e-4)
    assert all(a <= b for a, b in zip(lrs, lrs[1:]))


@pytest.mark.parametrize("name,path", [("mfcc-dnn", "memory"), ("mfcc-dnn", "streamed"), ("cccae", "memory")])
def test_large_batches_reach_the_standard_validation_loss(planted, name, path):
    """batch_scale 4 (batches of 1024 at 4× the learning rate): the regressor's best validation
    loss within 5 % of the standard path's on a planted corpus (the check's measure), and the
    share of the motion's variance it explains within a quarter of the standard path's."""
    corpus = planted(minutes=4.0, n_recordings=4, speakers=("a",), seed=7)
    params = {**TINY, "max_epochs": 6, "patience": 6, "ae_max_epochs": 3, "train_path": path}
    std = create(name, **params).fit(corpus)
    big = create(name, **params, batch_scale=4).fit(corpus)
    a, b = min(std.history_["regressor"]["valid"]), min(big.history_["regressor"]["valid"])
    assert abs(b - a) / a < 0.05, (a, b)
    assert (1 - b) > 0.75 * (1 - a) > 0, (a, b)  # and it learned as much (losses are on z-scored motion)
    assert big.history_["speed"]["batch_scale"] == 4 and "speed" not in std.history_
    assert np.isfinite(big.predict(corpus[0].audio, seed=0).rotvec).all()


def test_speed_parameters_are_checked(planted):
    from headmotion.errors import ParameterError

    corpus = planted(minutes=1.0, n_recordings=2, speakers=("a",), seed=2)
    for bad, match in (({"batch_scale": 0}, "batch_scale"), ({"precision": "fp8"}, "precision"),
                       ({"compile_networks": "yes"}, "compile_networks")):
        with pytest.raises(ParameterError, match=match):
            create("mfcc-dnn", **TINY, **bad).fit(corpus)
