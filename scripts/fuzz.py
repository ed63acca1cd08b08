#!/usr/bin/env python
"""Mutation fuzzer for every file reader of headmotion.

Seeds are small real-style files of every format the project reads, written here (the package's
own writers for BVH, Live Link, native csv/json/npz, wav/flac and model files; hand-made Motive
and OpenFace CSVs; a C3D made with ezc3d), so the fuzzer needs no data set.  Each mutation class
damages a seed the way files get damaged:

========== =====================================================================================
truncate   cut short at a random byte
flip       1–8 random bits flipped
number     a number replaced by nan, inf, -inf, 0, -1, 1e9, 1e-320, 1e308 or a 5000-digit integer
           (text: any number token; wav: a header field; npz/hmz: a stored value; c3d/flac: a
           header word)
header     the same, restricted to the header (declared counts, sizes and rates)
dupline    a line (text) or a block of bytes (binary) duplicated
delline    a line deleted (text) / a block of bytes removed (binary)
hugefield  a 300 000-character field inserted (text only)
nest       a JSON value wrapped in 100 000 brackets (json only)
========== =====================================================================================

Every mutated file is read in a **worker process** with an address-space limit (``--mem-mb``,
default 2048) and a time limit per input (``--timeout``, default 20 s); a worker that dies or
hangs counts as a crash and is replaced.  The outcome of one input is

* ``valid``   — the reader returned a finite motion at a sane rate (1–1000 fps), finite audio at
  1 kHz–384 kHz, or a model file's config and arrays; and ``headmotion info FILE`` exited 0;
* ``error``   — a :class:`~headmotion.errors.HeadMotionError` naming the file (``headmotion info``
  exits with 1–3 and one line);
* ``unnamed`` — a HeadMotionError whose message does not name the file;
* ``crash``   — any other exception, an absurd result, ``info`` exiting 4 (internal error), an
  out-of-memory or a hang.

Usage::

    python scripts/fuzz.py --minutes 10                # deep run, all formats, prints the table
    python scripts/fuzz.py --minutes 1 --formats bvh   # one format
    python scripts/fuzz.py --replay tests/data/fuzz    # replay the crash corpus
    python scripts/fuzz.py --minutes 10 --save-crashes tests/data/fuzz/crashes

The test suite (``tests/test_fuzz_readers.py``) drives the same mutations from hypothesis and
replays ``tests/data/fuzz/crashes/`` every run.  Libraries considered: atheris (coverage-guided,
but no wheel for this Python / needs clang to build); hypothesis (used by the tests; its
``find``/``given`` do not fit a time-boxed run, hence this loop).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import random
import select
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: format name -> file extension
FORMATS = {"bvh": ".bvh", "optitrack": ".csv", "livelink": ".csv", "openface": ".csv",
           "csv": ".csv", "json": ".json", "npz": ".npz", "c3d": ".c3d", "wav": ".wav",
           "flac": ".flac", "hmz": ".hmz"}
TEXT = {"bvh", "optitrack", "livelink", "openface", "csv", "json"}
CLASSES = ("truncate", "flip", "number", "header", "dupline", "delline", "hugefield", "nest")
SPECIAL = ("nan", "inf", "-inf", "0", "-1", "1e9", "1e-320", "1e308", "9" * 5000)


def classes_for(fmt: str) -> tuple[str, ...]:
    if fmt == "json":
        return CLASSES
    if fmt in TEXT:
        return CLASSES[:-1]
    return ("truncate", "flip", "number", "header", "dupline", "delline")


# ------------------------------------------------------------------------------------- seeds
def _motion(T=40, fps=30.0):
    import numpy as np

    from headmotion.types import Motion

    t = np.arange(T) / fps
    rv = np.stack([0.1 * np.sin(2 * np.pi * 0.7 * t), 0.2 * np.sin(2 * np.pi * 0.3 * t + 1),
                   0.05 * np.cos(2 * np.pi * 1.1 * t)], 1)
    return Motion(rv, fps, translation=np.zeros((T, 3)) + 0.01 * rv)


def _optitrack_text(T=40, fps=120.0) -> str:
    import numpy as np
    from scipy.spatial.transform import Rotation

    head = ["Format Version", "1.23", "Take Name", "fuzz", "Capture Frame Rate", f"{fps:.6f}",
            "Export Frame Rate", f"{fps:.6f}", "Total Frames in Take", str(T), "Total Exported Frames",
            str(T), "Rotation Type", "Quaternion", "Length Units", "Millimeters", "Coordinate Space",
            "Global"]
    bodies = ("Head", "Body")
    types = ["", "Type"] + ["Rigid Body"] * 14
    names = ["", "Name"] + [b for b in bodies for _ in range(7)]
    ids = ["", "ID"] + [str(k + 1) for k in range(2) for _ in range(7)]
    kinds = ["", ""] + (["Rotation"] * 4 + ["Position"] * 3) * 2
    axes = ["Frame", "Time (Seconds)"] + ["X", "Y", "Z", "W", "X", "Y", "Z"] * 2
    lines = [",".join(head), "", ",".join(types), ",".join(names), ",".join(ids), ",".join(kinds),
             ",".join(axes)]
    t = np.arange(T) / fps
    for k in range(T):
        row = [str(k), f"{t[k]:.6f}"]
        for b, amp in ((0, 0.2), (1, 0.05)):
            q = Rotation.from_rotvec([amp * np.sin(3 * t[k] + b), amp * np.cos(2 * t[k]), 0.03 * b]).as_quat()
            pos = [10.0 * b, 1500.0 - 400 * b + 5 * np.sin(t[k]), 3.0]
            row += [f"{v:.6f}" for v in q] + [f"{v:.6f}" for v in pos]
        if k in (7, 8):  # a short gap, as real takes have
            row[2:9] = [""] * 7
        lines.append(",".join(row))
    return "\n".join(lines) + "\n"


def _openface_text(T=40, fps=25.0) -> str:
    import numpy as np

    cols = ["frame", "face_id", "timestamp", "confidence", "success", "pose_Tx", "pose_Ty", "pose_Tz",
            "pose_Rx", "pose_Ry", "pose_Rz"]
    lines = [", ".join(cols)]
    for k in range(T):
        t = k / fps
        vals = [k + 1, 0, round(t, 3), 0.95 if k != 5 else 0.1, 1, 10 + k * 0.1, 40.0, 600.0,
                0.2 * np.sin(t), 0.1 * np.cos(2 * t), 0.02 * np.sin(3 * t)]
        lines.append(", ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in vals))
    return "\n".join(lines) + "\n"


def _c3d(path: Path, T=40, rate=100.0) -> None:
    import ezc3d
    import numpy as np

    names = ["LFHD", "RFHD", "LBHD", "RBHD", "C7", "T10", "CLAV", "STRN"]
    base = np.array([[80, 60, 1700], [-80, 60, 1700], [80, -100, 1690], [-80, -100, 1690],
                     [0, -120, 1500], [0, -130, 1200], [0, 80, 1450], [0, 90, 1250]], float)
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [rate]
    c["parameters"]["POINT"]["LABELS"]["value"] = names
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    pts = np.ones((4, len(names), T))
    for k in range(T):
        a = 0.1 * np.sin(k / 7)
        R = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
        p = base.copy()
        p[:4] = (p[:4] - p[:4].mean(0)) @ R.T + p[:4].mean(0)
        pts[:3, :, k] = p.T
    c["data"]["points"] = pts
    c.write(str(path))


def _hmz(path: Path) -> None:
    import numpy as np

    from headmotion.models.serialization import save_model_file

    save_model_file(path, system="tws-hier", config={"params": {"n_clusters": 4, "fps": 100},
                                                      "features": "f0e", "corpus": {"recordings": 2}},
                    arrays={"means": np.arange(12.0).reshape(4, 3), "weights": np.full(4, 0.25)})


def make_seed(fmt: str, directory: Path) -> Path:
    """Write the seed file of ``fmt`` into ``directory``; return its path."""
    import numpy as np

    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"seed_{fmt}{FORMATS[fmt]}"
    m = _motion()
    if fmt == "bvh":
        from headmotion.io.bvh import save_bvh

        save_bvh(m, path)
    elif fmt == "optitrack":
        path.write_text(_optitrack_text())
    elif fmt == "livelink":
        from headmotion.io.livelink import save_livelink

        save_livelink(m, path)
    elif fmt == "openface":
        path.write_text(_openface_text())
    elif fmt == "csv":
        from headmotion.io.native import save_csv

        save_csv(m, path)
    elif fmt == "json":
        from headmotion.io.native import save_json

        save_json(m, path)
    elif fmt == "npz":
        from headmotion.io.native import save_npz

        save_npz(m, path)
    elif fmt == "c3d":
        _c3d(path)
    elif fmt in ("wav", "flac"):
        import soundfile as sf

        t = np.arange(1600) / 16000
        sf.write(str(path), 0.3 * np.sin(2 * np.pi * 220 * t), 16000, subtype="PCM_16")
    elif fmt == "hmz":
        _hmz(path)
    else:
        raise ValueError(fmt)
    return path


# --------------------------------------------------------------------------------- mutations
def _num_spans(text: str, limit: int | None = None):
    import re

    return [m.span() for m in re.finditer(r"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?", text[:limit])]


def _mutate_text(data: bytes, cls: str, rng: random.Random, fmt: str) -> bytes:
    text = data.decode("utf-8", errors="replace")
    lines = text.split("\n")
    if cls in ("number", "header"):
        limit = None
        if cls == "header":  # where the declared counts, sizes and rates are
            cut = {"bvh": text.find("\n", text.find("Frame Time")) + 1,
                   "optitrack": text.find("\n") + 1,
                   "json": text.find('"frames"') if '"frames"' in text else 200,
                   "csv": text.find("\n") + 1}.get(fmt, len(lines[0]) + 1 + (len(lines[1]) if len(lines) > 1 else 0))
            limit = max(cut, 1)
        spans = _num_spans(text, limit)
        if cls == "header" and fmt == "bvh":  # the declared counts and rate, not the offsets
            import re

            decl = [m.span(1) for m in re.finditer(r"(?m)^\s*(?:Frames:|Frame Time:|CHANNELS)\s*(\S+)", text)]
            spans = decl or spans
        if not spans:
            return _mutate_bytes(data, "flip", rng)
        a, b = rng.choice(spans)
        return (text[:a] + rng.choice(SPECIAL) + text[b:]).encode()
    if cls == "dupline":
        k = rng.randrange(len(lines))
        n = rng.choice((1, 1, 2, 50))
        return "\n".join(lines[:k + 1] + lines[k:k + 1] * n + lines[k + 1:]).encode()
    if cls == "delline":
        k = rng.randrange(len(lines))
        return "\n".join(lines[:k] + lines[k + 1:]).encode()
    if cls == "hugefield":
        k = rng.randrange(len(lines))
        sep = "," if fmt != "bvh" else " "
        fill = rng.choice(("x" * 300_000, "1" * 300_000, '"' + "a" * 300_000))
        return "\n".join(lines[:k] + [lines[k] + sep + fill] + lines[k + 1:]).encode()
    if cls == "nest":
        depth = rng.choice((1000, 100_000))
        key = rng.choice(('"frames":', '"meta":', '"fps":'))
        i = text.find(key)
        if i < 0:
            return ("[" * depth + "]" * depth).encode()
        j = i + len(key)
        return (text[:j] + "[" * depth + "]" * depth + ',"_x":' + text[j:]).encode()
    return _mutate_bytes(data, cls, rng)


def _mutate_bytes(data: bytes, cls: str, rng: random.Random) -> bytes:
    b = bytearray(data)
    if not b:
        return bytes(b)
    if cls == "truncate":
        return bytes(b[:rng.randrange(len(b))])
    if cls == "flip":
        for _ in range(rng.randint(1, 8)):
            i = rng.randrange(len(b))
            b[i] ^= 1 << rng.randrange(8)
        return bytes(b)
    if cls == "dupline":
        i = rng.randrange(len(b))
        n = rng.choice((1, 4, 64, 512))
        return bytes(b[:i] + b[i:i + n] + b[i:])
    if cls == "delline":
        i = rng.randrange(len(b))
        n = rng.choice((1, 4, 64, 512))
        return bytes(b[:i] + b[i + n:])
    if cls in ("number", "header"):
        i = rng.randrange(min(len(b), 512 if cls == "header" else len(b)) - 3) if len(b) > 4 else 0
        word = rng.choice((b"\x00\x00\x00\x00", b"\xff\xff\xff\xff", b"\xff\xff\xff\x7f",
                           struct.pack("<f", float("nan")), struct.pack("<f", float("inf")),
                           struct.pack("<I", 10**9), b"\x01\x00\x00\x00"))
        b[i:i + 4] = word[:len(b) - i]
        return bytes(b)
    return bytes(b)


def _special_float(rng: random.Random) -> float:
    return float(rng.choice(("nan", "inf", "-inf", "0", "-1", "1e9", "1e-320", "1e308")))


def _mutate_wav_header(data: bytes, rng: random.Random) -> bytes:
    b = bytearray(data)
    off, size = rng.choice(((4, 4), (22, 2), (24, 4), (28, 4), (32, 2), (34, 2), (40, 4), (16, 4)))
    val = rng.choice((0, 1, 3, 0xFFFF, 0xFFFFFFFF, 0x7FFFFFFF, 10**9 & 0xFFFFFFFF, 7))
    b[off:off + size] = (val & ((1 << (8 * size)) - 1)).to_bytes(size, "little")
    return bytes(b)


def _mutate_npz(path: Path, rng: random.Random) -> bytes:
    import numpy as np

    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    key = rng.choice(("rotvec", "fps", "fps", "translation", "meta_json", "shape"))
    if key == "fps":
        arrays["fps"] = np.float64(_special_float(rng))
    elif key == "meta_json":
        arrays["meta_json"] = np.array(rng.choice(("{", "[" * 100_000, "null", '{"a": ' + "9" * 5000 + "}")))
    elif key == "shape":
        arrays["rotvec"] = rng.choice((np.zeros((0, 3)), np.zeros((5, 4)), np.zeros(7), np.zeros((2, 2, 3)),
                                       np.array(["a", "b"])))
    else:
        a = arrays[key].copy()
        a.flat[rng.randrange(a.size)] = _special_float(rng)
        arrays[key] = a
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _mutate_hmz(path: Path, rng: random.Random) -> bytes:
    import zipfile

    with zipfile.ZipFile(path) as zf:
        config = json.loads(zf.read("config.json"))
        arrays = zf.read("arrays.npz")
    what = rng.choice(("config", "config", "bomb", "arrays"))
    if what == "config":
        key = rng.choice(sorted(config))
        config[key] = rng.choice((None, -1, 10**50, "x" * 10, [], {"a": [1] * 3}, float("nan")))
        text = json.dumps(config)
    elif what == "arrays":
        text = json.dumps(config)
        arrays = arrays[:rng.randrange(len(arrays))]
    else:  # a member that claims (and holds) a huge uncompressed size: a zip bomb in small
        text = json.dumps(config)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("config.json", text)
        if what == "bomb":
            zf.writestr("arrays.npz", b"\0" * (rng.choice((64, 600)) << 20))
        else:
            zf.writestr("arrays.npz", arrays)
    return buf.getvalue()


def mutate(fmt: str, seed_path: Path, cls: str, rng: random.Random) -> bytes:
    """A mutated copy (bytes) of the seed file of ``fmt`` by mutation class ``cls``."""
    data = seed_path.read_bytes()
    if fmt in TEXT:
        return _mutate_text(data, cls, rng, fmt)
    if cls in ("number", "header"):
        if fmt == "wav":
            return _mutate_wav_header(data, rng)
        if fmt == "npz":
            return _mutate_npz(seed_path, rng)
        if fmt == "hmz":
            return _mutate_hmz(seed_path, rng)
    return _mutate_bytes(data, cls, rng)


# ----------------------------------------------------------------------------------- targets
def _sane_motion(m) -> str | None:
    import numpy as np

    if not np.all(np.isfinite(m.rotvec)) or len(m) == 0:
        return "non-finite or empty motion"
    if not 1.0 <= m.fps <= 1000.0:
        return f"absurd frame rate {m.fps!r}"
    return None


def run_target(fmt: str, path: str) -> dict:
    """Read ``path`` as ``fmt`` with the library and with ``headmotion info``; classify."""
    import warnings

    from headmotion.errors import HeadMotionError

    name = Path(path).name
    result = {"outcome": "valid", "detail": ""}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if fmt in ("wav", "flac"):
                from headmotion.io.audio import audio_info, load_audio

                a = load_audio(path)
                import numpy as np

                if not (1000 <= a.sample_rate <= 384000) or not np.all(np.isfinite(a.samples)):
                    return {"outcome": "crash", "detail": f"absurd audio: rate {a.sample_rate}"}
                audio_info(path)
            elif fmt == "hmz":
                from headmotion.models.serialization import load_model_file

                config, arrays = load_model_file(path)
                if not isinstance(config, dict) or not isinstance(arrays, dict):
                    return {"outcome": "crash", "detail": "load_model_file returned garbage"}
            else:
                from headmotion.io.motion import load_motion

                reader = {"bvh": "bvh", "optitrack": "optitrack", "livelink": "livelink",
                          "openface": "openface", "csv": "csv", "json": "json", "npz": "npz",
                          "c3d": "c3d"}[fmt]
                m = load_motion(path, format=reader)
                bad = _sane_motion(m)
                if bad:
                    return {"outcome": "crash", "detail": bad}
    except HeadMotionError as exc:
        msg = str(exc)
        result = {"outcome": "error" if name in msg else "unnamed",
                  "detail": f"{type(exc).__name__}: {msg[:200]}"}
    except RecursionError:
        return {"outcome": "crash", "detail": "RecursionError"}
    except BaseException as exc:  # noqa: BLE001 - everything else is what we look for
        return {"outcome": "crash", "detail": f"{type(exc).__name__}: {str(exc)[:200]}"}
    # the CLI's printer must survive whatever the reader accepted (or report the same error)
    try:
        from headmotion.cli import main

        out, err = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["info", path])
        if not isinstance(code, int) or "internal error" in err.getvalue():
            return {"outcome": "crash", "detail": f"info exit {code}: {err.getvalue().strip()[:200]}"}
        if code != 0 and len(err.getvalue().strip().splitlines()) > 1:
            return {"outcome": "crash", "detail": f"info printed {len(err.getvalue().splitlines())} lines"}
    except BaseException as exc:  # noqa: BLE001
        return {"outcome": "crash", "detail": f"info: {type(exc).__name__}: {str(exc)[:200]}"}
    return result


# ------------------------------------------------------------------------------------ worker
def worker_main(mem_mb: int) -> None:
    """Read ``{"fmt", "path"}`` lines on stdin, answer one JSON line each on stdout."""
    import resource

    if mem_mb > 0:
        lim = mem_mb << 20
        resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
    sys.setrecursionlimit(10_000)
    out = sys.stdout
    sys.stdout = sys.stderr  # stray prints must not corrupt the protocol
    # import once, so each input costs only its own reading
    import headmotion.cli  # noqa: F401
    import headmotion.io.audio  # noqa: F401
    import headmotion.io.motion  # noqa: F401
    import headmotion.models.serialization  # noqa: F401

    out.write(json.dumps({"ready": True}) + "\n")
    out.flush()
    for line in sys.stdin:
        req = json.loads(line)
        res = run_target(req["fmt"], req["path"])
        out.write(json.dumps(res) + "\n")
        out.flush()


class Worker:
    """A worker process with memory and time limits; replaced when it dies or hangs."""

    def __init__(self, mem_mb: int = 2048, timeout: float = 20.0, env: dict | None = None):
        self.mem_mb, self.timeout, self.env = mem_mb, timeout, env
        self.proc = None

    def _start(self):
        env = dict(os.environ if self.env is None else self.env)
        env.setdefault("OMP_NUM_THREADS", "1")
        env.setdefault("NUMBA_NUM_THREADS", "1")
        self.proc = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--worker", "--mem-mb", str(self.mem_mb)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env,
            text=True, bufsize=1)
        ready = self._readline(120.0)
        if ready is None:
            raise RuntimeError("fuzz worker did not start")

    def _readline(self, timeout: float):
        r, _, _ = select.select([self.proc.stdout], [], [], timeout)
        if not r:
            return None
        line = self.proc.stdout.readline()
        return json.loads(line) if line else None

    def run(self, fmt: str, path: str) -> dict:
        if self.proc is None or self.proc.poll() is not None:
            self._start()
        try:
            self.proc.stdin.write(json.dumps({"fmt": fmt, "path": str(path)}) + "\n")
            self.proc.stdin.flush()
        except BrokenPipeError:
            self.close()
            return {"outcome": "crash", "detail": "worker died"}
        res = self._readline(self.timeout)
        if res is None:
            died = self.proc.poll() is not None
            rc = self.proc.returncode
            self.close()
            return {"outcome": "crash",
                    "detail": f"worker died (exit {rc}; out of memory?)" if died else f"hang (> {self.timeout:g} s)"}
        return res

    def close(self):
        if self.proc is not None:
            with contextlib.suppress(Exception):
                self.proc.kill()
                self.proc.wait(5)
            self.proc = None


# ----------------------------------------------------------------------------------- driver
def replay(directory: Path, worker: Worker) -> list[tuple[Path, dict]]:
    """Read every file under ``directory`` (``<fmt>/<name>``) and return the outcomes."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for p in sorted(directory.rglob("*")):
            if p.is_file() and p.parent.name in FORMATS:
                out.append((p, worker.run(p.parent.name, str(corpus_file(p, Path(tmp))))))
    return out


def corpus_file(p: Path, tmp: Path) -> Path:
    """A corpus entry as a readable file: large inputs are stored gzipped (``NAME.EXT.gz``)."""
    if p.suffix != ".gz":
        return p
    import gzip

    out = tmp / p.name[:-3]
    out.write_bytes(gzip.decompress(p.read_bytes()))
    return out


def fuzz(minutes: float, formats, *, worker: Worker, save_crashes: Path | None = None,
         seed: int = 0, log=print, inputs: int | None = None) -> dict:
    rng = random.Random(seed)
    table: dict = {}
    crashes: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        seeds = {f: make_seed(f, tmp / "seeds") for f in formats}
        for f, s in seeds.items():  # every seed itself must read
            r = worker.run(f, str(s))
            if r["outcome"] != "valid":
                raise RuntimeError(f"seed {f} does not read: {r}")
        end = time.monotonic() + minutes * 60
        n = 0
        while (time.monotonic() < end) if inputs is None else (n < inputs):
            fmt = formats[n % len(formats)]
            cls = rng.choice(classes_for(fmt))
            data = mutate(fmt, seeds[fmt], cls, random.Random(rng.getrandbits(64)))
            path = tmp / f"in{FORMATS[fmt]}"
            path.write_bytes(data)
            res = worker.run(fmt, str(path))
            cell = table.setdefault((fmt, cls), {"valid": 0, "error": 0, "unnamed": 0, "crash": 0})
            cell[res["outcome"]] += 1
            if res["outcome"] in ("crash", "unnamed"):
                key = (fmt, res["detail"].split(":")[0][:60], cls)
                if key not in crashes:
                    crashes[key] = res["detail"]
                    log(f"[{fmt}/{cls}] {res['outcome']}: {res['detail'][:160]}")
                    if save_crashes is not None and res["outcome"] == "crash":
                        d = save_crashes / fmt
                        d.mkdir(parents=True, exist_ok=True)
                        digest = hashlib.sha1(data).hexdigest()[:12]
                        name = f"{cls}-{digest}{FORMATS[fmt]}"
                        if len(data) > 16384:  # stored gzipped: corpus_file() unpacks it
                            import gzip

                            (d / f"{name}.gz").write_bytes(gzip.compress(data, 9, mtime=0))
                        else:
                            (d / name).write_bytes(data)
            n += 1
    return {"inputs": n, "table": table, "crashes": crashes}


def format_table(table: dict) -> str:
    lines = ["| reader | mutation | valid | clear error | unnamed error | crash |", "|---|---|---|---|---|---|"]
    for (fmt, cls), c in sorted(table.items()):
        lines.append(f"| {fmt} | {cls} | {c['valid']} | {c['error']} | {c['unnamed']} | {c['crash']} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, default=1.0)
    ap.add_argument("--inputs", type=int, help="stop after this many inputs (instead of --minutes)")
    ap.add_argument("--formats", default=",".join(FORMATS))
    ap.add_argument("--mem-mb", type=int, default=2048)
    ap.add_argument("--timeout", type=float, default=20.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--save-crashes", type=Path)
    ap.add_argument("--replay", type=Path)
    ap.add_argument("--json", type=Path, help="write the table and crashes as JSON here")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        worker_main(a.mem_mb)
        return 0
    w = Worker(a.mem_mb, a.timeout)
    try:
        if a.replay:
            res = replay(a.replay, w)
            bad = [(p, r) for p, r in res if r["outcome"] in ("crash", "unnamed")]
            for p, r in res:
                print(f"{r['outcome']:8s} {p}  {r['detail'][:120]}")
            print(f"{len(res)} inputs replayed, {len(bad)} crash/unnamed")
            return 1 if bad else 0
        formats = [f.strip() for f in a.formats.split(",") if f.strip()]
        t0 = time.monotonic()
        res = fuzz(a.minutes, formats, worker=w, save_crashes=a.save_crashes, seed=a.seed,
                    inputs=a.inputs)
    finally:
        w.close()
    n_crash = sum(c["crash"] for c in res["table"].values())
    print(format_table(res["table"]))
    print(f"\n{res['inputs']} inputs in {time.monotonic() - t0:.0f} s; {n_crash} crashed "
          f"({len(res['crashes'])} distinct crash/unnamed signatures)")
    if a.json:
        a.json.write_text(json.dumps({"inputs": res["inputs"],
                                      "table": {f"{k[0]}|{k[1]}": v for k, v in res["table"].items()},
                                      "crashes": {"|".join(k): v for k, v in res["crashes"].items()}},
                                     indent=1))
    return 1 if n_crash else 0


if __name__ == "__main__":
    sys.exit(main())
