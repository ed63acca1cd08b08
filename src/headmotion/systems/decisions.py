"""A stream's decisions as questions to a shared search: what lets one engine advance many streams.

A stream that searches a library at each decision (motion-match's streams) can be pushed *step by
step*: ``push_steps(samples)`` (and ``flush_steps()``) is a generator that yields an *ask* — an
object with the ``library`` searched and the decision's ``query`` — and is sent the library's
costs for that query (``library.costs_many([query])[0]``); its value is what ``push`` returns.
:func:`run_alone` answers each ask on its own (``push`` is ``run_alone(push_steps(...))``);
:func:`answer_together` answers the asks of many streams with one ``costs_many`` per library (one
matrix product per table), which gives each ask the row it gets alone, so a stream decides the
same among others as alone.  A stream without steps is pushed as it is (:func:`steps_of`).
"""

from __future__ import annotations


def answer_alone(ask):
    """The library's costs for ``ask`` alone (None for an ask without a query)."""
    return None if ask.query is None else ask.library.costs_many([ask.query])[0]


def answer_together(asks: list) -> list:
    """The library's costs for each of ``asks`` (None where an ask has no query): one
    ``costs_many`` per library, each row the one its ask gets alone."""
    out: list = [None] * len(asks)
    groups: dict[int, list[int]] = {}
    for i, a in enumerate(asks):
        if a.query is not None:
            groups.setdefault(id(a.library), []).append(i)
    for idx in groups.values():
        rows = asks[idx[0]].library.costs_many([asks[i].query for i in idx])
        for i, r in zip(idx, rows):
            out[i] = r
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


__all__ = ["answer_alone", "answer_together", "run_alone", "steps_of"]
