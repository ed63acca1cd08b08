"""Running the installed ``headmotion`` command (no Blender module needed).

``headmotion synth AUDIO -o MOTION.json --fps F -m MODEL --seed N --amount A`` writes the motion
at the scene's frame rate; its JSON (headmotion's native format) holds rotation vectors in
radians, one row per frame.  Errors come back as ``headmotion``'s own one-line ``error:`` message.
"""

import json
import os
import shutil
import subprocess
import tempfile


class RunError(Exception):
    """A one-line reason why no motion came back."""


def find_executable(preference=""):
    """The ``headmotion`` to run: the path set in the add-on's preferences, else the one on PATH."""
    if preference:
        path = os.path.abspath(os.path.expanduser(preference))
        if os.path.isdir(path):
            path = os.path.join(path, "headmotion")
        if not (os.path.isfile(path) and os.access(path, os.X_OK)):
            raise RunError(f"the headmotion command set in the add-on's preferences is not a program: {path}")
        return path
    found = shutil.which("headmotion")
    if found is None:
        raise RunError("the headmotion command was not found on PATH; install it (pip install headmotion) or set its "
                       "path in the add-on's preferences")
    return found


def synth_command(executable, audio, output, fps, model, seed, amount):
    """The command line of one synthesis."""
    return [executable, "synth", audio, "-o", output, "--fps", f"{fps:.10g}", "-m", model or "default",
            "--seed", str(int(seed)), "--amount", f"{amount:.10g}"]


def _environment():
    env = dict(os.environ)
    for name in ("PYTHONHOME", "PYTHONPATH"):  # Blender's own Python must not leak into headmotion's
        env.pop(name, None)
    return env


class Synthesis:
    """One ``headmotion synth`` run in the background: :meth:`poll`, :meth:`cancel`, :meth:`result`."""

    def __init__(self, executable, audio, fps, model, seed, amount):
        self.dir = tempfile.mkdtemp(prefix="headmotion_blender_")
        self.output = os.path.join(self.dir, "motion.json")
        self._err = open(os.path.join(self.dir, "stderr.txt"), "w+", encoding="utf-8")
        try:
            self.proc = subprocess.Popen(synth_command(executable, audio, self.output, fps, model, seed, amount),
                                         stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=self._err,
                                         env=_environment())
        except OSError as exc:
            self.close()
            raise RunError(f"cannot run {executable}: {exc.strerror or exc}") from None

    def poll(self):
        """True once the command has ended."""
        return self.proc.poll() is not None

    def wait(self):
        self.proc.wait()

    def cancel(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.close()

    def result(self):
        """``(fps, frames)`` of the motion; raises :class:`RunError` with headmotion's message."""
        try:
            if self.proc.returncode != 0:
                raise RunError(self._error_line())
            return read_motion(self.output)
        finally:
            self.close()

    def _error_line(self):
        self._err.seek(0)
        lines = [ln.strip() for ln in self._err.read().splitlines() if ln.strip()]
        errors = [ln for ln in lines if ln.startswith("error:")]
        line = (errors or lines or [f"headmotion ended with exit code {self.proc.returncode}"])[-1]
        return line[len("error:"):].strip() if line.startswith("error:") else line

    def close(self):
        if not self._err.closed:
            self._err.close()
        shutil.rmtree(self.dir, ignore_errors=True)


def read_motion(path):
    """``(fps, [[rx, ry, rz], ...])`` from headmotion's JSON motion file."""
    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
        frames = doc["frames"]
        if doc.get("rotation", "rotvec") != "rotvec" or doc.get("units", "rad") != "rad":
            raise ValueError("not rotation vectors in radians")
        return float(doc["fps"]), [(float(a), float(b), float(c)) for a, b, c in frames]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise RunError(f"headmotion wrote no readable motion ({exc})") from None
