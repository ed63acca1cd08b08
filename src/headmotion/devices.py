"""Where the torch-trained systems run: the ``device`` parameter of motion-flow and the DNN
systems (``"auto"``: CUDA when torch sees one, else the CPU)."""

from __future__ import annotations

import os

from .errors import ParameterError

DEVICES = ("auto", "cpu", "cuda")


def check_device(device, owner: str) -> None:
    """Raise ParameterError unless ``device`` is one of :data:`DEVICES` (``owner`` names the system)."""
    if device not in DEVICES:
        raise ParameterError(f"{owner}: device must be one of {list(DEVICES)}; got {device!r}")


def resolve_device(device: str) -> str:
    """``"cuda"`` or ``"cpu"`` for the ``device`` parameter (``"auto"``: CUDA when torch sees one);
    ``"cuda"`` without a CUDA device is refused."""
    import torch

    if device == "auto":
        device = "cuda" if torch.cuda.is_available() else "cpu"
    if device == "cuda" and not torch.cuda.is_available():
        raise ParameterError("device='cuda' but torch sees no CUDA device; use device='cpu' or 'auto'")
    if device == "cuda":  # cuBLAS's deterministic mode, for training under deterministic algorithms
        os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
    return device


__all__ = ["DEVICES", "check_device", "resolve_device"]
