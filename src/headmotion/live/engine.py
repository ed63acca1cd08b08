"""One engine per process for every live stream: the decisions of all of them made together.

A live core's push (:class:`~headmotion.live.core.HeadMotionCore`) resamples the audio, reads its
prosody and, every few frames, makes a decision: the costs of every frame of the model's library
(about 21 000 for the shipped ``stream``) for the speech so far, then a draw.  Made stream by
stream, each decision is a few matrix–vector products over the library; made together, the
decisions due across all streams are one matrix product per table
(:meth:`Library.costs_many <headmotion.systems.motion_match.library.Library.costs_many>`), which
reads the library once instead of once per stream.

:class:`LiveEngine` is the live core's many-streams form.  ``await engine.push(core, samples,
rate)`` (and :meth:`~LiveEngine.hear`, :meth:`~LiveEngine.end`) runs the core's push step by step
(:meth:`~headmotion.live.core.HeadMotionCore.push_steps`): the audio is read at once, in the
caller's task; a push that makes no decision returns at once, and one that asks for a decision
waits for the engine's *tick*.  The tick runs as soon as the event loop is free, so it gathers
every decision asked since the last one (under load, all that arrived while the last tick ran;
alone, a stream waits for nothing but the next turn of the loop), answers them with one search per
model library (:func:`~headmotion.systems.decisions.answer_together`) and lets each push go on to
its frames — or to its next decision, answered in the same tick.

A stream that reads pitch with Praat frame by frame (the shipped ``stream``) asks for its reads
too: a push that makes a 40 ms frame ready asks for Praat's candidates of its analysis windows,
and a tick reads every stream's windows by one Praat call
(:class:`~headmotion.features.praat_path.Read`).  A read asked while no tick is due is read at once
in the caller's task (a lone stream never waits for a tick to read); one asked while a tick is due
joins it.

A stream's frames are those it gets alone (the batched costs are the bits of a lone decision's;
``tests/test_batched_engine.py``), whatever joins or leaves.  One core's calls run in order: a call
made while the core's previous call waits for a tick waits behind it.  :func:`run_together` is the
same without an event loop: given the step generators of many streams, it runs them to their ends
together.
"""

from __future__ import annotations

import asyncio
import weakref
from dataclasses import dataclass

from ..errors import ParameterError
from ..systems.decisions import answer_alone, answer_together, is_read, run_alone


def run_together(steps: list) -> list:
    """Run many step generators (``core.push_steps(...)`` …) to their ends together, every round's
    asks answered in one batch; returns their values, in order (an exception a generator raised
    in its place)."""
    out: list = [None] * len(steps)
    pending = []
    for i, s in enumerate(steps):
        _advance(s, None, i, out, pending, first=True)
    while pending:
        pending = _round(pending, out)
    return out


def _advance(steps, row, key, out, pending: list, *, first: bool = False) -> None:
    """One step of one generator: its next ask into ``pending``, or its value (or exception) into
    ``out[key]`` (a dict or list)."""
    try:
        ask = next(steps) if first else steps.send(row)
    except StopIteration as stop:
        out[key] = stop.value
    except Exception as exc:  # noqa: BLE001 - one stream's failure is its own
        out[key] = exc
    else:
        pending.append((steps, ask, key))


def _round(pending: list, out) -> list:
    """Answer every pending ask together and advance each generator once; the asks still pending."""
    try:
        rows = answer_together([a for _, a, _ in pending])
    except Exception as exc:  # noqa: BLE001 - a search that failed fails every stream that asked
        for steps, _, key in pending:
            steps.close()
            out[key] = exc
        return []
    nxt: list = []
    for (steps, _, key), row in zip(pending, rows):
        _advance(steps, row, key, out, nxt)
    return nxt


def _retrieved(fut: asyncio.Future) -> None:
    if not fut.cancelled():
        fut.exception()


@dataclass
class EngineStats:
    """What an engine has done: ticks run, decisions answered, the largest tick (asks: decisions
    and pitch reads), pitch reads answered in ticks (not those read at once while no tick was due)
    and the ticks that made a decision."""

    ticks: int = 0
    decisions: int = 0
    largest: int = 0
    reads: int = 0
    decision_ticks: int = 0

    @property
    def mean_batch(self) -> float:
        """Decisions answered per tick that made one, on average."""
        return self.decisions / self.decision_ticks if self.decision_ticks else 0.0


class LiveEngine:
    """Every live stream of an event loop advanced together (module docstring); one per worker
    process."""

    def __init__(self):
        self.stats = EngineStats()
        self._pending: list = []  # (steps, ask, future) waiting for the next tick
        self._tick = None
        self._busy: dict[int, asyncio.Future] = {}  # a core's call waiting for a tick

    async def push(self, core, samples, sample_rate: int):
        """:meth:`HeadMotionCore.push <headmotion.live.core.HeadMotionCore.push>` with its
        decisions made together with the other streams'; the FrameBatch."""
        return await self.run(core, lambda: core.push_steps(samples, sample_rate))

    async def hear(self, core, samples, sample_rate: int):
        """:meth:`HeadMotionCore.hear <headmotion.live.core.HeadMotionCore.hear>` through the engine."""
        return await self.run(core, lambda: core.hear_steps(samples, sample_rate))

    async def end(self, core) -> list:
        """:meth:`HeadMotionCore.end <headmotion.live.core.HeadMotionCore.end>` through the engine."""
        return await self.run(core, core.end_steps)

    def finish(self, core) -> None:
        """Bring ``core``'s call that waits for a tick to its end now (the tick runs at once, for
        every stream waiting), so that code which uses the core without the engine (an
        interruption, a pause) finds it between calls.  Nothing when none waits."""
        if id(core) in self._busy:
            if self._tick is not None:
                self._tick.cancel()
            self._run_tick()

    async def run(self, core, make_steps):
        """Run ``make_steps()`` — a generator of ``core``'s decisions, e.g. ``core.push_steps(...)``
        or a pacing layer's ``pacer.audio_steps(...)`` — with its decisions answered in the ticks;
        its value.  The generator is made once the core's previous call through the engine has
        ended."""
        key = id(core)
        while key in self._busy:  # the core's previous call first (its state moves in order)
            try:
                await asyncio.shield(self._busy[key])
            except Exception:  # noqa: BLE001 - its caller has it; this call starts afresh
                pass
        steps = make_steps()
        out: dict = {}
        pending: list = []
        _advance(steps, None, 0, out, pending, first=True)
        while pending and self._tick is None and is_read(pending[0][1]):
            # a pitch read while no tick is due (no other stream waits): read at once, in the
            # caller's task (the same bits as in a tick), so a lone stream never waits for one
            s, ask, k = pending.pop(0)
            _advance(s, answer_alone(ask), k, out, pending)
        if not pending:  # no decision due: done at once, in the caller's task
            value = out[0]
            if isinstance(value, Exception):
                raise value
            return value
        loop = asyncio.get_running_loop()
        fut = loop.create_future()
        fut.add_done_callback(_retrieved)  # a failure whose caller went away is not logged as lost
        self._busy[key] = fut
        self._pending.append((pending[0][0], pending[0][1], fut))
        if self._tick is None:
            self._tick = loop.call_soon(self._run_tick)
        return await asyncio.shield(fut)  # a caller that goes away leaves the tick to finish the push

    def _run_tick(self) -> None:
        """The tick: every decision asked since the last one, answered together, round by round."""
        self._tick = None
        todo, self._pending = self._pending, []
        futures = {id(fut): fut for _, _, fut in todo}
        pending = [(steps, ask, id(fut)) for steps, ask, fut in todo]
        st = self.stats
        st.ticks += 1
        st.largest = max(st.largest, len(pending))
        out: dict = {}
        decided = False
        while pending:
            reads = sum(1 for _, ask, _ in pending if is_read(ask))
            st.reads += reads
            st.decisions += len(pending) - reads
            decided = decided or len(pending) > reads
            pending = _round(pending, out)
        st.decision_ticks += decided
        self._busy = {k: f for k, f in self._busy.items() if id(f) not in futures}
        for key, value in out.items():
            fut = futures[key]
            if fut.done():  # its caller went away
                continue
            if isinstance(value, Exception):
                fut.set_exception(value)
            else:
                fut.set_result(value)


_LOOP_ENGINES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def loop_engine() -> LiveEngine:
    """The running event loop's engine: every live stream of the loop that asks for it (the Pipecat
    and LiveKit processors of one process) shares it."""
    loop = asyncio.get_running_loop()
    eng = _LOOP_ENGINES.get(loop)
    if eng is None:
        eng = _LOOP_ENGINES[loop] = LiveEngine()
    return eng


class EngineUse:
    """A live path's way to the engine (the voice-agent processors): ``engine`` True — the running
    loop's (:func:`loop_engine`, found at the first call), False — none (each decision alone; the
    frames are the same), or a :class:`LiveEngine`."""

    def __init__(self, engine: LiveEngine | bool = True):
        if not isinstance(engine, (bool, LiveEngine)):
            raise ParameterError(f"engine must be True, False or a LiveEngine; got {engine!r}")
        self._loop = engine is True  # the running loop's, found at the first call
        self.engine: LiveEngine | None = engine if isinstance(engine, LiveEngine) else None

    async def run(self, core, make_steps):
        """``make_steps()``'s value, its decisions answered by the engine (alone without one)."""
        if self.engine is None and self._loop:
            self.engine = loop_engine()
        if self.engine is None:
            return run_alone(make_steps())
        return await self.engine.run(core, make_steps)

    def finish(self, core) -> None:
        """:meth:`LiveEngine.finish` (before the path uses ``core`` without the engine)."""
        if self.engine is not None:
            self.engine.finish(core)


__all__ = ["LiveEngine", "EngineStats", "EngineUse", "loop_engine", "run_together"]
