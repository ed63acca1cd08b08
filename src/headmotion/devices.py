"""Where the torch-trained systems run: the ``device`` parameter of motion-flow and the DNN
systems (``"auto"``: CUDA when torch sees one, else the CPU), and PyTorch itself, which is optional
(the ``nets`` extra): :func:`import_torch` names the extra when it is missing."""

from __future__ import annotations

import importlib.util
import os

from .errors import MissingDependencyError, ParameterError

DEVICES = ("auto", "cpu", "cuda")

#: how to install PyTorch, in every message that asks for it
TORCH_HINT = ("pip install 'headmotion[nets]' (CPU-only: pip install torch==2.13.0 "
              "--index-url https://download.pytorch.org/whl/cpu)")


def has_torch() -> bool:
    """Whether PyTorch can be imported (without importing it)."""
    try:
        return importlib.util.find_spec("torch") is not None
    except (ImportError, ValueError):  # an import hook that refuses it
        return False


def missing_torch(purpose: str = "this network system (cccae, ae-dnn, the *-dnn systems, motion-flow)"):
    """The :class:`MissingDependencyError` (exit 3) for a missing PyTorch; ``purpose`` says what needs it."""
    return MissingDependencyError(f"{purpose} needs PyTorch, which is not installed: {TORCH_HINT}")


def import_torch(purpose: str | None = None):
    """The ``torch`` module, or :func:`missing_torch`'s error naming the ``nets`` extra when it is not
    installed (``purpose`` says what needs it)."""
    try:
        import torch
    except ModuleNotFoundError as exc:
        if (exc.name or "").split(".")[0] != "torch":
            raise
        raise (missing_torch() if purpose is None else missing_torch(purpose)) from None
    return torch


def check_device(device, owner: str) -> None:
    """Raise ParameterError unless ``device`` is one of :data:`DEVICES` (``owner`` names the system)."""
    if device not in DEVICES:
        raise ParameterError(f"{owner}: device must be one of {list(DEVICES)}; got {device!r}")


def resolve_device(device: str) -> str:
    """``"cuda"`` or ``"cpu"`` for the ``device`` parameter (``"auto"``: CUDA when torch sees one);
    ``"cuda"`` without a CUDA device is refused; a missing PyTorch names the ``nets`` extra."""
    torch = import_torch()

    if device == "auto":
        device = "cuda" if torch.cuda.is_available() else "cpu"
    if device == "cuda" and not torch.cuda.is_available():
        raise ParameterError("device='cuda' but torch sees no CUDA device; use device='cpu' or 'auto'")
    if device == "cuda":  # cuBLAS's deterministic mode, for training under deterministic algorithms
        os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
    return device


__all__ = ["DEVICES", "TORCH_HINT", "check_device", "has_torch", "import_torch", "missing_torch", "resolve_device"]
