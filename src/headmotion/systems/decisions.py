"""A stream's decisions as questions to a shared search: what lets one engine advance many streams.

A stream that searches a library at each decision (motion-match's streams) can be pushed *step by
step*: ``push_steps(samples)`` (and ``flush_steps()``) is a generator that yields an *ask* — an
object with the ``library`` searched and the decision's ``query`` — and is sent the library's
costs for that query (``library.costs_many([query])[0]``); its value is what ``push`` returns.
:func:`run_alone` answers each ask on its own (``push`` is ``run_alone(push_steps(...))``);
:func:`answer_together` answers the asks of many streams with one ``costs_many`` per library (one
matrix product per table), which gives each ask the row it gets alone, so a stream decides the
same among others as alone.  A stream whose pitch reader reads Praat frame by frame
(:class:`~headmotion.features.praat_path.PraatPathF0e`) also asks for its reads
(:class:`~headmotion.features.praat_path.Read`): :func:`answer_together` reads the windows of many
streams by one Praat call, each read given the candidates it gets alone.  A stream without steps
is pushed as it is (:func:`steps_of`).
"""

from __future__ import annotations

import numpy as np


def is_read(ask) -> bool:
    """Whether ``ask`` is a pitch read (:class:`headmotion.features.praat_path.Read`), not a decision."""
    return getattr(ask, "windows", None) is not None


def answer_alone(ask):
    """The library's costs for ``ask`` alone (None for an ask without a query); for a pitch read
    (:class:`headmotion.features.praat_path.Read`), its candidates."""
    if is_read(ask):
        return ask.answer()
    return None if ask.query is None else ask.library.costs_many([ask.query])[0]


def answer_together(asks: list) -> list:
    """The library's costs for each of ``asks`` (None where an ask has no query): one
    ``costs_many`` per library, each row the one its ask gets alone; and the candidates of every
    pitch read, one Praat call per reading's settings, each read's rows those it gets alone."""
    out: list = [None] * len(asks)
    groups: dict[int, list[int]] = {}
    reads: dict[tuple, list[int]] = {}
    for i, a in enumerate(asks):
        if is_read(a):
            reads.setdefault(a.settings, []).append(i)
        elif a.query is not None:
            groups.setdefault(id(a.library), []).append(i)
    for idx in groups.values():
        rows = asks[idx[0]].library.costs_many([asks[i].query for i in idx])
        for i, r in zip(idx, rows):
            out[i] = r
    for idx in reads.values():
        got = asks[idx[0]].answer(np.concatenate([asks[i].windows for i in idx]))
        o = 0
        for i in idx:
            n = len(asks[i].windows)
            out[i] = tuple(x[o:o + n] for x in got)
            o += n
    return out


def run_alone(steps):
    """Run a generator of asks to its end, each ask answered alone; returns its value."""
    try:
        ask = next(steps)
        while True:
            ask = steps.send(answer_alone(ask))
    except StopIteration as stop:
        return stop.value


def steps_of(stream, method: str, *args):
    """``stream.<method>_steps(*args)`` when the stream has steps, else a generator that asks
    nothing and returns ``stream.<method>(*args)``."""
    steps = getattr(stream, method + "_steps", None)
    if steps is not None:
        return (yield from steps(*args))
    return getattr(stream, method)(*args)


__all__ = ["answer_alone", "answer_together", "is_read", "run_alone", "steps_of"]
