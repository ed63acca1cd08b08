"""The live engine (headmotion.live.engine): many streams' decisions made together, each stream's
frames those it gets alone.

Known answers: the library's many-query costs are, row by row, the bits of each query alone (the
BLAS property they rest on is checked for the BLAS installed); streams of different models,
lookaheads, seeds and controls, some hearing the other party, joining and leaving between and
within ticks (a stream's end, flush included, in the same tick as others' pushes; an
interruption; a listening turn), give through the engine the frames each gives alone.
"""

from __future__ import annotations

import asyncio

import numpy as np
import pytest
import soundfile as sf
from threadpoolctl import threadpool_limits

from headmotion.live.core import FrameBatch, HeadMotionCore, UtteranceEnd
from headmotion.live.engine import LiveEngine, run_together
from headmotion.synthesis import load_model
from headmotion.systems.motion_match.library import Query, Weights, products

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]
SPEECH = ROOT / "examples" / "speech"
pytestmark = pytest.mark.timeout(600)


@pytest.fixture(scope="module")
def stream_model():
    return load_model("stream")


@pytest.fixture(scope="module")
def voices():
    a, sr = sf.read(SPEECH / "speech_female.wav", dtype="float32")
    b, sr_b = sf.read(SPEECH / "speech_male.wav", dtype="float32")
    assert sr == sr_b == 16000
    return a, b


def test_blas_products_do_not_depend_on_the_other_queries(stream_model):
    """The property the engine's exactness rests on: a query's row of :func:`products` is the same
    bits alone and among any others, at any place (the products are of blocks of 2, 4 or 8
    queries; a BLAS product of a varying number, or split between threads, rounds differently on
    some CPUs)."""
    lib = stream_model.library_
    rng = np.random.default_rng(0)
    for name in ("S", "P", "V", "G"):
        table = lib.tables[name]
        q = rng.standard_normal((40, table.shape[1])).astype(np.float32)
        whole = products(table, q)
        for n in (1, 2, 3, 4, 5, 8, 9, 11, 17, 40):  # blocks of 2, 4 and 8 queries, and mixtures
            assert np.array_equal(products(table, q[:n]), whole[:n]), (name, n)
        for i in (0, 5, 7, 8, 39):
            assert np.array_equal(products(table, q[i:i + 1])[0], whole[i]), (name, i)
        for k in range(3):  # the same query among other queries, at another place
            others = rng.standard_normal((23, table.shape[1])).astype(np.float32)
            mixed = np.insert(others, 3 + 7 * k, q[5], axis=0)
            assert np.array_equal(products(table, mixed)[3 + 7 * k], whole[5]), (name, k)
        for threads in (1, 2):  # and whatever the process's BLAS threads (predict runs on one)
            with threadpool_limits(limits=threads, user_api="blas"):
                assert np.array_equal(products(table, q), whole), (name, threads)
                assert np.array_equal(products(table, q[5:6])[0], whole[5]), (name, threads)


def test_costs_many_rows_are_the_costs_of_each_query_alone(stream_model):
    lib = stream_model.library_
    rng = np.random.default_rng(1)
    base = Weights.of(stream_model)
    ws = [base, Weights(**{**base.__dict__, "amount": 2.0}), Weights(**{**base.__dict__, "speech_weight": 0.5,
                                                                         "pause_speed": False})]
    D = lib.tables["S"].shape[1]
    goal_rows = len(stream_model._goal_steps)
    queries = []
    for k in range(12):
        pose = None if k % 4 == 0 else rng.normal(0, 3, 3)
        vel = None if pose is None else rng.normal(0, 0.5, 3)
        goal = None if k % 3 == 0 else np.repeat(rng.normal(0, 3, (1, 3)), goal_rows, axis=0)
        queries.append(Query(ws[k % 3], rng.standard_normal(D).astype(np.float32), pose, vel, goal,
                             float(k % 2), 3.0 if k == 5 else None))
    together = lib.costs_many(queries)
    assert together.shape == (12, len(lib.descriptors))
    for q, row in zip(queries, together):
        assert np.array_equal(lib.costs_many([q])[0], row)
        alone = lib.costs(q.w, q.s, q.pose, q.vel, q.goal, q.speaking, pause_weight=q.pause_weight)
        assert np.array_equal(alone, np.where(lib.can_start, row, np.inf))
    # a known answer: the speech cost alone is the weighted squared distance to each descriptor
    q = Query(Weights(**{**base.__dict__, "target_weight": 0.0, "pause_weight": 0.0, "amount": 1.0}),
              queries[1].s, None, None)
    want = ((lib.descriptors.astype(np.float64) - q.s.astype(np.float64)) ** 2).sum(axis=1) / D
    np.testing.assert_allclose(lib.costs_many([q])[0], want, rtol=1e-4, atol=1e-3)


def _plans(voices):
    """Streams: (core kwargs, first tick, [(kind, samples)] one per tick from the first).  Kinds:
    push, hear_along (the other party on the utterance's timeline), end, interrupt, listen (a
    listening turn: the core's hear)."""
    a, b = voices
    rng = np.random.default_rng(7)

    def chunks(x, n):
        cuts = np.sort(rng.choice(np.arange(1, len(x)), n - 1, replace=False))
        return np.split(x, cuts)

    plans = []
    # the shipped stream, default controls: the whole female voice, then an end (with its settling)
    plans.append((dict(seed=0), 0, [("push", c) for c in chunks(a[:16000 * 4], 60)] + [("end", None)]))
    # another seed, gain and offset, amount 2, joining late, leaving by interruption
    plans.append((dict(seed=3, gain=1.4, offset_degrees="3,-2,0", amount=2.0), 7,
                  [("push", c) for c in chunks(b[:16000 * 3], 40)] + [("interrupt", None)]))
    # reading 120 ms ahead (another library), hearing the other party along, ending in a tick with others
    hear = chunks(a[:16000 * 3] * 0.5, 35)
    steps = []
    for s, h in zip(chunks(b[16000:16000 * 4], 35), hear):
        steps += [("push", s), ("hear_along", h)]
    plans.append((dict(seed=11, lookahead_ms=120.0, heard_rate=16000), 3, steps + [("end", None)]))
    # the calmest head, amount 0.5, listening 2; speaks, ends, then listens in a listening turn
    steps = [("push", c) for c in chunks(a[16000 * 2:16000 * 4], 25)] + [("end", None)]
    steps += [("listen", c) for c in chunks(b[:16000 * 2], 25)]
    plans.append((dict(seed=5, amount=0.5, listening=2.0, settle_s=0.2), 12, steps))
    # a second utterance on one core after an end: a fresh stream on the same core
    steps = [("push", c) for c in chunks(b[:16000 * 2], 20)] + [("end", None)]
    steps += [("push", c) for c in chunks(a[:16000 * 2], 20)] + [("end", None)]
    plans.append((dict(seed=2, still=False, lookahead_ms=80.0), 20, steps))
    return plans


def _call_alone(core, kind, x):
    if kind == "push":
        return core.push(x, 16000)
    if kind == "hear_along":
        return core.hear_along(x)
    if kind == "end":
        return core.end()
    if kind == "interrupt":
        return core.interrupt()
    return core.hear(x, 16000)


def _steps(core, kind, x):
    if kind == "push":
        return core.push_steps(x, 16000)
    if kind == "end":
        return core.end_steps()
    if kind == "listen":
        return core.hear_steps(x, 16000)
    return None


def _frames(results) -> np.ndarray:
    rows = []
    for r in results:
        for item in (r if isinstance(r, list) else [r]):
            if isinstance(item, FrameBatch) and len(item):
                rows.append((item.first, item.settling, item.rotvec))
    return rows


def _compare(alone, together):
    fa, ft = _frames(alone), _frames(together)
    assert len(fa) == len(ft) and len(fa) > 0
    n = 0
    for (f1, s1, r1), (f2, s2, r2) in zip(fa, ft):
        assert (f1, s1) == (f2, s2) and r1.shape == r2.shape
        assert float(np.abs(r1 - r2).max(initial=0.0)) <= 1e-6
        n += len(r1)
    ends_a = [i for r in alone for i in (r if isinstance(r, list) else []) if isinstance(i, UtteranceEnd)]
    ends_t = [i for r in together for i in (r if isinstance(r, list) else []) if isinstance(i, UtteranceEnd)]
    assert ends_a == ends_t
    return n


def test_streams_through_the_engine_make_the_frames_they_make_alone(stream_model, voices):
    plans = _plans(voices)
    alone = []
    for kw, _first, steps in plans:
        core = HeadMotionCore(stream_model, **kw)
        alone.append([_call_alone(core, kind, x) for kind, x in steps])
    cores = [HeadMotionCore(stream_model, **kw) for kw, _f, _s in plans]
    together = [[] for _ in plans]
    ticks = max(first + len(steps) for _kw, first, steps in plans)
    sizes = []
    for tick in range(ticks):
        gens, owners = [], []
        for i, (_kw, first, steps) in enumerate(plans):
            k = tick - first
            if not 0 <= k < len(steps):
                continue  # not yet joined, or gone
            kind, x = steps[k]
            g = _steps(cores[i], kind, x)
            if g is None:  # no decision in it: called as it is
                together[i].append(_call_alone(cores[i], kind, x))
            else:
                gens.append(g)
                owners.append(i)
        sizes.append(len(gens))
        for i, value in zip(owners, run_together(gens)):
            assert not isinstance(value, Exception), value
            together[i].append(value)
    assert max(sizes) >= 4  # ticks held several streams at once
    made = [_compare(a, t) for a, t in zip(alone, together)]
    assert all(m > 20 for m in made), made


def test_the_streams_pitch_is_read_by_one_praat_call_for_all(stream_model, voices, monkeypatch):
    """Four streams pushed 20 ms at a time together: each round reads every stream's new analysis
    frames (two per 40 ms frame) by one Praat call, and each stream's frames are the ones it makes
    alone."""
    from headmotion.features import praat_path

    calls = []
    read = praat_path.praat_candidates

    def spy(windows, *a, **kw):
        calls.append(len(windows))
        return read(windows, *a, **kw)

    monkeypatch.setattr(praat_path, "praat_candidates", spy)
    a, b = voices
    xs = [a[:32000], b[:32000], a[8000:40000], b[8000:40000]]
    alone = []
    for k, x in enumerate(xs):
        core = HeadMotionCore(stream_model, seed=k)
        alone.append([core.push(x[i:i + 320], 16000) for i in range(0, len(x), 320)])
    calls_alone = len(calls)
    calls.clear()
    cores = [HeadMotionCore(stream_model, seed=k) for k in range(len(xs))]
    together = [[] for _ in xs]
    for i in range(0, 32000, 320):
        for k, value in enumerate(run_together([c.push_steps(x[i:i + 320], 16000) for c, x in zip(cores, xs)])):
            assert not isinstance(value, Exception), value
            together[k].append(value)
    assert all(n % len(xs) == 0 for n in calls) and len(calls) <= calls_alone / len(xs) + 2
    for w, g in zip(alone, together):
        _compare(w, g)


def test_the_async_engine_gathers_decisions_and_keeps_each_stream_its_own(stream_model, voices):
    a, b = voices
    xs = [a[:16000 * 3], b[:16000 * 3], a[16000:16000 * 4], b[8000:16000 * 3 + 8000]]
    kws = [dict(seed=k, lookahead_ms=40.0 * (k % 2)) for k in range(len(xs))]

    def alone(kw, x):
        core = HeadMotionCore(stream_model, **kw)
        return [core.push(x[i:i + 320], 16000) for i in range(0, len(x), 320)] + [core.end()]

    want = [alone(kw, x) for kw, x in zip(kws, xs)]

    async def main():
        eng = LiveEngine()

        async def one(kw, x, delay):
            core = HeadMotionCore(stream_model, **kw)
            await asyncio.sleep(delay)
            out = []
            for i in range(0, len(x), 320):
                out.append(await eng.push(core, x[i:i + 320], 16000))
                await asyncio.sleep(0)
            out.append(await eng.end(core))
            return out

        got = await asyncio.gather(*[one(kw, x, 0.001 * k) for k, (kw, x) in enumerate(zip(kws, xs))])
        return got, eng.stats

    got, stats = asyncio.run(main())
    for w, g in zip(want, got):
        _compare(w, g)
    assert stats.decisions > 0 and stats.largest >= 2 and stats.mean_batch > 1.0 and stats.reads > 0


def test_one_cores_calls_run_in_order_and_errors_are_its_own(stream_model, voices):
    a, _b = voices

    async def main():
        eng = LiveEngine()
        core, other = HeadMotionCore(stream_model, seed=0), HeadMotionCore(stream_model, seed=1)
        x = a[:16000]
        # two pushes of one core at once: the second waits behind the first
        first, second = await asyncio.gather(eng.push(core, x[:8000], 16000), eng.push(core, x[8000:], 16000))
        # a bad rate on one stream fails that call alone
        from headmotion.errors import SampleRateError

        with pytest.raises(SampleRateError):
            await eng.push(core, x[:320], 8000)
        ok = await eng.push(other, x, 16000)
        return first, second, ok

    first, second, ok = asyncio.run(main())
    ref = HeadMotionCore(stream_model, seed=0)
    r1, r2 = ref.push(a[:8000], 16000), ref.push(a[8000:16000], 16000)
    assert (first.first, second.first) == (r1.first, r2.first)
    assert np.array_equal(first.rotvec, r1.rotvec) and np.array_equal(second.rotvec, r2.rotvec)
    assert len(ok) > 0


def test_a_caller_that_goes_away_leaves_the_engine_whole(stream_model, voices):
    """A push whose caller is cancelled while it waits for a tick finishes in the tick; the core's
    next push goes on from there, as if the cancelled push had been awaited."""
    a, _b = voices
    x = a[:16000]

    async def main():
        eng = LiveEngine()
        core = HeadMotionCore(stream_model, seed=4)
        task = asyncio.ensure_future(eng.push(core, x[:8000], 16000))
        await asyncio.sleep(0)  # the push has read its audio and asked for a decision
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        return await eng.push(core, x[8000:], 16000), eng.stats

    after, stats = asyncio.run(main())
    ref = HeadMotionCore(stream_model, seed=4)
    ref.push(x[:8000], 16000)
    want = ref.push(x[8000:], 16000)
    assert stats.ticks >= 1
    assert after.first == want.first and np.array_equal(after.rotvec, want.rotvec)


def test_finish_ends_a_waiting_call_so_a_call_without_the_engine_follows_it(stream_model, voices):
    """An interruption (a call that does not go through the engine) made while the core's push waits
    for a tick: ``finish`` runs the tick at once, so the push ends first and the settling starts
    where it left the head — the frames of push-then-interrupt alone; the push's caller gets its
    batch."""
    a, _b = voices
    x = a[:16000]

    async def main():
        eng = LiveEngine()
        core, other = HeadMotionCore(stream_model, seed=5), HeadMotionCore(stream_model, seed=6)
        task = asyncio.ensure_future(eng.push(core, x[:8000], 16000))
        task_other = asyncio.ensure_future(eng.push(other, x[:8000], 16000))
        await asyncio.sleep(0)  # both pushes have read their audio and asked for a decision
        assert not task.done() and eng.stats.ticks == 0
        eng.finish(core)
        assert eng.stats.ticks == 1 and eng.stats.largest == 2  # the other stream's ask went too
        items = core.interrupt()
        eng.finish(core)  # nothing waits: nothing happens
        assert eng.stats.ticks == 1
        return await task, await task_other, items

    pushed, _, items = asyncio.run(main())
    ref = HeadMotionCore(stream_model, seed=5)
    want = ref.push(x[:8000], 16000)
    want_items = ref.interrupt()
    assert pushed.first == want.first and np.array_equal(pushed.rotvec, want.rotvec)
    assert len(items) == len(want_items)
    for got, ref_item in zip(items, want_items):
        if isinstance(ref_item, FrameBatch):
            assert np.array_equal(got.rotvec, ref_item.rotvec)
        else:
            assert got == ref_item
