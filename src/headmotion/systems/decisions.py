"""A stream's decisions as questions to a shared search: what lets one engine advance many streams.

A stream that searches a library at each decision (motion-match's streams) can be pushed *step by
step*: ``push_steps(samples)`` (and ``flush_steps()``) is a generator that yields an *ask* and is
sent its answer; its value is what ``push`` returns.  An ask says how it is answered together with
others: ``ask.batch`` — the asks with the same key are answered together (None: nothing to answer)
— and ``type(ask).answer_many(asks)``, which gives each ask the answer it gets alone.  A decision
(:class:`~headmotion.systems.motion_match.walk.Ask`) is answered with its library's costs for its
query, many by one ``costs_many`` (one matrix product per table); a stream whose pitch reader reads
Praat frame by frame (:class:`~headmotion.features.praat_path.PraatPathF0e`) also asks for its reads
(:class:`~headmotion.features.praat_path.Read`), many read by one Praat call.  :func:`run_alone`
answers each ask on its own (``push`` is ``run_alone(push_steps(...))``); :func:`answer_together`
answers the asks of many streams, so a stream decides the same among others as alone.  A stream
without steps is pushed as it is (:func:`steps_of`).
"""

from __future__ import annotations


def is_read(ask) -> bool:
    """Whether ``ask`` is a pitch read (:class:`headmotion.features.praat_path.Read`), not a decision."""
    return getattr(ask, "windows", None) is not None


def answer_alone(ask):
    """``ask``'s answer on its own (None for an ask without one)."""
    return None if ask.batch is None else type(ask).answer_many([ask])[0]


def answer_together(asks: list) -> list:
    """Each of ``asks``'s answer (None where an ask has none): the asks with the same ``batch``
    answered by one ``answer_many``, each given what it gets alone."""
    out: list = [None] * len(asks)
    groups: dict = {}
    for i, a in enumerate(asks):
        if a.batch is not None:
            groups.setdefault(a.batch, []).append(i)
    for idx in groups.values():
        for i, r in zip(idx, type(asks[idx[0]]).answer_many([asks[i] for i in idx])):
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


__all__ = ["answer_alone", "answer_together", "is_read", "run_alone", "steps_of"]
