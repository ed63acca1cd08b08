"""Whether a stream is a terminal (progress bars and wrapping are for terminals only)."""

from __future__ import annotations


def is_terminal(stream) -> bool:
    """True when ``stream`` is an open terminal; False when piped, redirected, replaced or closed."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # replaced or closed
        return False


__all__ = ["is_terminal"]
