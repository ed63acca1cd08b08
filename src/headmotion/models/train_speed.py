"""How the network systems' training loops use their device: batch scaling with a scaled learning
rate and warm-up, the optimiser (fused Adam on a GPU), bf16 autocast and ``torch.compile`` on a GPU.

:class:`Speed` is built from a system's parameters (``batch_scale``, ``precision``,
``compile_networks``) and the resolved device.  Its defaults change nothing: batches of the given
size, plain Adam at the given rate, float32, eager — the CPU models bit for bit.

* ``batch_scale`` k (any device): batches k times larger and the learning rate × k (linear
  scaling, Goyal et al. 2017), reached by a linear warm-up over the first :data:`WARMUP_STEPS`
  optimiser steps.  Fewer, larger steps keep a GPU busy: a batch of 256 frames through these small
  networks leaves it waiting on kernel launches.  Measured on the CPU (8-minute planted corpus,
  ``docs/decisions/gpu-training.md``): at k = 4 the regressor's best validation loss within 0.3 %
  of the standard path's, the post-filter's trained to early stopping within 3.4 % (√k scaling:
  22 %; k = 8 linear: 9 %), so 4 is the scale to use.
* ``precision="bf16"``: forward passes under ``torch.autocast(bfloat16)``, on a GPU only (on the
  CPU they stay float32), and never the CCA term (:mod:`.dcca` needs float32's range and
  precision: a Cholesky factor of an ill-conditioned covariance).
* ``compile_networks``: the forward function ``torch.compile``-d on a GPU only; if compiling fails
  the loop runs eagerly (a warning says why).
* On a GPU Adam is ``fused=True`` (one kernel per step instead of one per parameter and op).
* With scaled batches the regressor's dropout masks are drawn on the device (no copy per batch);
  with the standard batches on the CPU, as the CPU path draws them.
"""

from __future__ import annotations

import contextlib
import warnings
from dataclasses import dataclass

#: optimiser steps over which a scaled learning rate is reached from the unscaled one
WARMUP_STEPS = 50
#: the values of the systems' ``precision`` parameter
PRECISIONS = ("float32", "bf16")


class WarmAdam:
    """Adam whose learning rate rises linearly from ``lr / scale`` to ``lr`` over the first
    ``warmup`` steps (duck-types the optimiser for :func:`headmotion.models.nets.descend`)."""

    def __init__(self, params, lr: float, *, fused: bool, scale: float, warmup: int):
        import torch

        kw = {"fused": True} if fused else {}
        self.opt = torch.optim.Adam(params, lr=lr, **kw)
        self.lr, self.start, self.warmup, self.steps = float(lr), float(lr) / max(scale, 1.0), int(warmup), 0

    def zero_grad(self) -> None:
        self.opt.zero_grad()

    def step(self) -> None:
        if self.steps < self.warmup:
            f = (self.steps + 1) / self.warmup
            for g in self.opt.param_groups:
                g["lr"] = self.start + (self.lr - self.start) * f
        self.opt.step()
        self.steps += 1


@dataclass(frozen=True)
class Speed:
    """A training loop's use of its device (module docstring)."""

    device: str = "cpu"
    batch_scale: int = 1
    precision: str = "float32"
    compile_networks: bool = False

    @classmethod
    def of(cls, system, device: str) -> "Speed":
        """The settings of ``system``'s parameters (absent ones at their defaults) on ``device``."""
        return cls(device, int(getattr(system, "batch_scale", 1) or 1), str(getattr(system, "precision", "float32")),
                   bool(getattr(system, "compile_networks", False)))

    @property
    def cuda(self) -> bool:
        return self.device.startswith("cuda")

    def batch(self, size: int) -> int:
        """The batch size for a loop whose standard batch is ``size``."""
        return int(size) * self.batch_scale

    def lr(self, lr: float) -> float:
        """The learning rate for batches :meth:`batch` large (× ``batch_scale``)."""
        return float(lr) * self.batch_scale

    def adam(self, params, lr: float):
        """Adam at :meth:`lr` (fused on a GPU; a :class:`WarmAdam` when the batches are scaled);
        ``torch.optim.Adam(params, lr)`` with the defaults on the CPU."""
        import torch

        if self.batch_scale == 1:
            return torch.optim.Adam(params, lr=lr, **({"fused": True} if self.cuda else {}))
        return WarmAdam(params, self.lr(lr), fused=self.cuda, scale=float(self.batch_scale), warmup=WARMUP_STEPS)

    def prepare(self, module):
        """``module`` with its dropout set for these settings: masks drawn on the CPU (the CPU's
        model on a GPU) unless the batches are scaled (:class:`~headmotion.models.nets.HostDropout`)."""
        for m in module.modules():
            if hasattr(m, "host"):
                m.host = self.batch_scale == 1
        return module

    def autocast(self):
        """bf16 autocast for a forward pass on a GPU with ``precision="bf16"``; else nothing."""
        if self.precision == "bf16" and self.cuda:
            import torch

            return torch.autocast("cuda", dtype=torch.bfloat16)
        return contextlib.nullcontext()

    def forward(self, module):
        """``module``'s forward, ``torch.compile``-d on a GPU when asked, falling back to eager."""
        if not (self.compile_networks and self.cuda):
            return module
        import torch

        state = {"fn": torch.compile(module, dynamic=True)}

        def call(*args):
            if state["fn"] is not module:
                try:
                    return state["fn"](*args)
                except Exception as exc:  # noqa: BLE001 - any compiler failure: train eagerly
                    warnings.warn(f"torch.compile failed ({type(exc).__name__}: {exc}); training eagerly",
                                  RuntimeWarning, stacklevel=2)
                    state["fn"] = module
            return module(*args)

        return call

    def describe(self) -> dict:
        """What was in effect, for a model's history."""
        return {"batch_scale": self.batch_scale, "precision": self.precision if self.cuda else "float32",
                "compiled": bool(self.compile_networks and self.cuda), "fused_adam": self.cuda}


__all__ = ["Speed", "WarmAdam", "WARMUP_STEPS", "PRECISIONS"]
