"""A library of voice lines to motion files in one call: what ``headmotion synth IN... -o DIR`` does.

:func:`synthesize_batch` finds the inputs (:mod:`.inputs`), skips those whose outputs are up to
date (:mod:`.manifest`), and makes the rest with :func:`headmotion.synthesis.synthesize` and
:func:`headmotion.io.save_motion` — the calls of ``headmotion synth`` for one file, so every
output is the file a single run writes (byte for byte).  Where they run:

* ``jobs=1``: in this process, one after another;
* ``jobs=N``: N worker processes, each given the loaded model once when it starts (forked where
  the platform forks, so the model is not copied at all), with one BLAS thread each; the workers
  write the files;
* ``scheduler=ADDRESS`` (or a ``distributed.Client``): a Dask cluster, as ``evaluate`` uses one
  (:func:`headmotion.parallel.dask_client`); the model is sent once to every worker
  (``Client.scatter(..., broadcast=True)``), the workers read the inputs by path (shared storage,
  as for ``evaluate``'s corpus) and send the motions back; this process writes them.

A damaged or missing input is reported (``report``) and the others are still made; every file is
written atomically, and the manifest line of an input is added once its files are complete, so an
interrupted batch resumes where it stopped.

Libraries considered: :mod:`concurrent.futures` (the standard library) runs the local workers —
joblib's ``Parallel`` has no per-worker initialiser to hand the model over once; dask.distributed
runs the clusters.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import pickle
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator

from ..errors import HeadMotionError, ParameterError
from ..synthesis import Controls, _controls, _with_amount, _with_lookahead, _with_stochastic, load_model, synthesize
from .inputs import Job, plan_jobs
from .manifest import Manifest, file_digest, options_key


@dataclass(frozen=True)
class Settings:
    """What every job of a batch shares besides the model."""

    seed: int
    samples: int
    controls: Controls
    save_options: dict
    write: bool = True  # the worker writes the files (False: it sends the motions back)


@dataclass
class Outcome:
    """One job's result: its input's [size, mtime_ns] and SHA-256, the motions when they were not
    written where they were made, or the one-line error and its exit code."""

    job: Job
    stat: list | None = None
    sha256: str | None = None
    motions: list | None = None
    error: str | None = None
    exit_code: int = 0


@dataclass
class BatchResult:
    """What a batch did: inputs written, skipped as up to date, and failed (with their message)."""

    written: list = field(default_factory=list)
    skipped: list = field(default_factory=list)
    failed: list = field(default_factory=list)  # (input, message)
    seconds: float = 0.0
    exit_code: int = 0  # 0, or the largest exit code of a failed input (1 bad input, 4 a bug)

    @property
    def total(self) -> int:
        return len(self.written) + len(self.skipped) + len(self.failed)


def _named(message: str, source: Path) -> str:
    return message if str(source) in message else f"{source}: {message}"


def write_outputs(job: Job, motions, save_options: dict) -> None:
    """Save one job's motions to its output files (as ``headmotion synth`` saves them)."""
    from ..io import save_motion

    for path, motion in zip(job.outputs, motions):
        save_motion(motion, path, **save_options)


def synth_one(job: Job, model, settings: Settings) -> Outcome:
    """Make one input's motions (and write them when ``settings.write``); errors are returned."""
    src = job.source
    try:
        if not src.is_file():
            raise HeadMotionError(f"{src}: {'is a folder' if src.is_dir() else 'file not found'}; expected an "
                                  "audio or video file")
        st = os.stat(src)
        sha = file_digest(src)
        motions = synthesize(src, model, seed=settings.seed, samples=settings.samples, controls=settings.controls)
        if settings.write:
            write_outputs(job, motions, settings.save_options)
            motions = None
        return Outcome(job, [st.st_size, st.st_mtime_ns], sha, motions)
    except HeadMotionError as exc:
        return Outcome(job, error=_named(str(exc), src), exit_code=int(getattr(exc, "exit_code", 1)))
    except OSError as exc:
        return Outcome(job, error=_named(f"cannot access {exc.filename or src}: {exc.strerror or exc}", src),
                       exit_code=1)
    except Exception as exc:  # noqa: BLE001 - a bug on one input must not lose the others
        return Outcome(job, error=_named(f"internal error {type(exc).__name__}: {exc} (this is a bug in headmotion, "
                                         "please report it)", src), exit_code=4)


# -- where the jobs run ------------------------------------------------------------------------------
_WORKER: tuple | None = None  # (model, settings) of a local worker process


def _init_worker(model, settings: Settings) -> None:
    global _WORKER
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)  # N workers on N cores: one BLAS thread each
    _WORKER = (model, settings)


def _synth_in_worker(job: Job) -> Outcome:
    model, settings = _WORKER
    return synth_one(job, model, settings)


def _synth_on_dask(job: Job, model, settings: Settings) -> Outcome:
    return synth_one(job, model, settings)


def _run_serial(todo, model, settings) -> Iterator[Outcome]:
    for job in todo:
        yield synth_one(job, model, settings)


def _mp_context():
    import multiprocessing

    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else None)


def _run_processes(todo, model, settings, jobs: int) -> Iterator[Outcome]:
    with ProcessPoolExecutor(max_workers=jobs, mp_context=_mp_context(), initializer=_init_worker,
                             initargs=(model, settings)) as pool:
        pending = {pool.submit(_synth_in_worker, job) for job in todo}
        try:
            while pending:
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    yield fut.result()
        finally:
            for fut in pending:
                fut.cancel()


def _run_dask(todo, model, settings, scheduler) -> Iterator[Outcome]:
    from ..parallel import dask_client

    with dask_client(scheduler) as client:
        from distributed import as_completed

        model_f = client.scatter(model, broadcast=True)  # once per worker, not once per file
        settings_f = client.scatter(dataclasses.replace(settings, write=False), broadcast=True)
        futures = client.map(_synth_on_dask, todo, model=model_f, settings=settings_f, pure=False)
        try:
            for fut in as_completed(futures):
                yield fut.result()
        finally:
            client.cancel(futures)


# -- the batch -----------------------------------------------------------------------------------------
def _model_identity(model, loaded) -> str:
    """The model's identity in the options key: its file's SHA-256, or a loaded model's pickle's."""
    if isinstance(model, (str, os.PathLike)):
        from ..shipped import resolve_model_path

        return "file:" + file_digest(resolve_model_path(model))
    return "object:" + hashlib.sha256(pickle.dumps(loaded, protocol=4)).hexdigest()


def _controls_identity(c: Controls) -> dict:
    d = dataclasses.asdict(c)
    if not d["lookahead_ms"]:  # the key of outputs made before there was a lookahead stays theirs
        del d["lookahead_ms"]
    ref = c.style_from
    if ref is not None:
        if isinstance(ref, (str, os.PathLike)):
            d["style_from"] = "file:" + file_digest(ref) if Path(ref).is_file() else str(ref)
        else:  # a Motion
            import numpy as np

            d["style_from"] = "motion:" + hashlib.sha256(np.ascontiguousarray(ref.rotvec).tobytes()
                                                         + repr(ref.fps).encode()).hexdigest()
    return d


def _prepare(model, seed, samples, controls, neck_share, fmt):
    """The loaded model, the settings and the options key; the options are checked here, once."""
    from .. import __version__
    from ..seeds import check_seed, model_seed

    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise ParameterError(f"samples (--samples) must be a whole number >= 1; got {samples!r}")
    check_seed(seed, samples, allow_none=True)
    if neck_share is not None:
        if fmt not in ("bvh", "glb", "gltf"):
            raise ParameterError(f"--neck-share applies to the bvh, glb and gltf formats; got {fmt!r}")
        if not 0.0 <= float(neck_share) <= 1.0:
            raise ParameterError(f"--neck-share must be between 0 and 1; got {neck_share}")
    m = load_model(model)
    seed = model_seed(m, seed)
    check_seed(seed, samples)
    _with_lookahead(_with_amount(_with_stochastic(m, controls.stochastic, samples), controls.amount),
                    controls.lookahead_ms)  # refused now, not per file
    save = {} if neck_share is None else {"neck_share": float(neck_share)}
    settings = Settings(seed, samples, controls, save)
    key = options_key({"headmotion": __version__, "model": _model_identity(model, m), "seed": seed,
                       "samples": samples, "format": fmt, "save": save, "controls": _controls_identity(controls)})
    return m, settings, key


def synthesize_batch(inputs, out_dir, model="default", *, format: str = "bvh", jobs: int = 1, scheduler=None,
                     force: bool = False, seed: int | None = None, samples: int = 1, neck_share: float | None = None,
                     controls: Controls | None = None, progress: Callable | None = None,
                     report: Callable | None = None, **controls_kwargs) -> BatchResult:
    """Head motion for many speech files: one motion file per input under ``out_dir``.

    Parameters
    ----------
    inputs : iterable of str or Path
        Speech files, folders (searched recursively) or ``"@list.txt"`` (:mod:`headmotion.batch.inputs`).
    out_dir : str or Path
        Where the outputs go; names and sub-folders mirror the inputs.
    model : str, Path or Synthesizer
        A shipped name, a model file or a loaded model, loaded once for the whole batch.
    format : {"bvh", "glb", "gltf", "csv", "json", "npz"}
    jobs : int
        Worker processes on this machine (1: in this process).
    scheduler : str or distributed.Client, optional
        A Dask scheduler address: run on that cluster instead (``jobs`` is ignored).
    force : bool
        Make every input again, even those whose outputs are up to date.
    seed, samples, neck_share, controls, **controls_kwargs
        As for :func:`headmotion.synthesize` and ``headmotion synth`` (neck_share: bvh, glb, gltf).
    progress : callable, optional
        ``progress(done, total)`` over the inputs to make, after each one.
    report : callable, optional
        ``report(input, status, message)`` after each input: ``"written"``, ``"skipped"`` (up to
        date) or ``"failed"`` with its one-line message.

    Returns
    -------
    BatchResult
        The inputs written, skipped and failed; ``exit_code`` is 0 when none failed.
    """
    t0 = time.perf_counter()
    c = _controls(controls, controls_kwargs)
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ParameterError(f"jobs (--jobs) must be a whole number >= 1; got {jobs!r}")
    out_dir = Path(out_dir)
    plan = plan_jobs(inputs, out_dir, format, samples)
    m, settings, key = _prepare(model, seed, samples, c, neck_share, format)
    result = BatchResult()
    manifest = Manifest(out_dir)
    say = report or (lambda *_a: None)
    try:
        todo = []
        for job in plan:
            if not force and manifest.up_to_date(job.name, job.source, key):
                result.skipped.append(job.source)
                say(job.source, "skipped", "")
            else:
                todo.append(job)
        manifest.compact()
        if scheduler is not None:
            outcomes = _run_dask(todo, m, settings, scheduler)
        elif jobs == 1 or len(todo) <= 1:
            outcomes = _run_serial(todo, m, settings)
        else:
            outcomes = _run_processes(todo, m, settings, min(jobs, len(todo)))
        for done, out in enumerate(outcomes, 1):
            _finish(out, manifest, key, settings, result, say)
            if progress is not None:
                progress(done, len(todo))
    finally:
        manifest.close()
    result.seconds = time.perf_counter() - t0
    return result


def _finish(out: Outcome, manifest: Manifest, key: str, settings: Settings, result: BatchResult, say) -> None:
    """Write what came back as motions, record the input, and report it."""
    job = out.job
    if out.error is None and out.motions is not None:
        try:
            write_outputs(job, out.motions, settings.save_options)
        except (HeadMotionError, OSError) as exc:
            out.error, out.exit_code = _named(str(exc), job.source), 1
    if out.error is not None:
        result.failed.append((job.source, out.error))
        result.exit_code = max(result.exit_code, out.exit_code)
        say(job.source, "failed", out.error)
        return
    manifest.record(job.name, job.source, key, out.stat, out.sha256, job.outputs)
    result.written.append(job.source)
    say(job.source, "written", "")


__all__ = ["BatchResult", "Settings", "synth_one", "synthesize_batch", "write_outputs"]
