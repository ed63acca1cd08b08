"""``headmotion plot`` and :func:`headmotion.render.plot_motion`; also the ``render`` CLI."""

from __future__ import annotations

import numpy as np
import pytest

from headmotion.errors import ParameterError
from headmotion.types import Audio, Motion


def _motion(fps=50.0, n=150, amp=(10, 20, 5)):
    t = np.arange(n) / fps
    deg = np.stack([amp[0] * np.sin(2 * np.pi * 0.5 * t), amp[1] * np.sin(2 * np.pi * 0.3 * t),
                    amp[2] * np.sin(2 * np.pi * 0.7 * t)], 1)
    return Motion.from_euler(deg[:, [1, 0, 2]], "YXZ", fps, degrees=True)


def _voice(dur=3.0, sr=16000, f0=150.0):
    t = np.arange(int(dur * sr)) / sr
    x = sum(np.sin(2 * np.pi * k * f0 * t) / k for k in range(1, 8))
    x[: sr // 2] = 0  # half a second of silence
    return Audio((0.2 * x).astype(np.float32), sr)


def test_plot_lines_are_degrees_per_axis(tmp_path):
    from headmotion.render import plot_motion

    a, b = _motion(), _motion(amp=(5, 10, 2.5))
    out = tmp_path / "fig.png"
    fig = plot_motion([a, b], out, labels=["truth", "half"])
    assert out.is_file() and out.stat().st_size > 10_000
    axes = fig.axes
    assert len(axes) == 3
    for k, amp in enumerate((10, 20, 5)):
        lines = axes[k].get_lines()
        ys = [ln.get_ydata() for ln in lines if len(ln.get_xdata()) == len(a)]
        assert len(ys) == 2
        assert np.max(np.abs(ys[0])) == pytest.approx(amp, rel=0.05)  # degrees, right axis
        assert np.max(np.abs(ys[1])) == pytest.approx(amp / 2, rel=0.05)
    assert [t.get_text() for t in axes[0].get_legend().get_texts()] == ["truth", "half"]
    assert axes[-1].get_xlim()[1] == pytest.approx(3.0)


def test_plot_with_speech_and_f0(tmp_path):
    from headmotion.render import plot_motion

    out = tmp_path / "fig.pdf"
    fig = plot_motion(_motion(), out, audio=_voice())
    assert out.read_bytes()[:4] == b"%PDF"
    assert len(fig.axes) == 5  # 3 axes + waveform + F0 twin
    f0 = fig.axes[-1].get_lines()[0].get_ydata()
    voiced = f0[np.isfinite(f0)]
    assert len(voiced) > 100 and np.median(voiced) == pytest.approx(150, rel=0.03)


def test_plot_bad_input(tmp_path):
    from headmotion.render import plot_motion

    with pytest.raises(ParameterError, match="labels"):
        plot_motion([_motion()], tmp_path / "x.png", labels=["a", "b"])
    with pytest.raises(ParameterError, match=".png"):
        plot_motion(_motion(), tmp_path / "x.txt")
    assert not (tmp_path / "x.png").exists()


# -- CLI -----------------------------------------------------------------------------------------
@pytest.fixture
def motion_files(tmp_path):
    try:
        from headmotion.io import save_motion
    except ImportError as exc:
        pytest.skip(f"motion I/O not available: {exc}")
    a, b = tmp_path / "truth.npz", tmp_path / "system.npz"
    save_motion(_motion(fps=25.0, n=25), a)
    save_motion(_motion(fps=25.0, n=25).scaled(0.5), b)
    import soundfile as sf

    wav = tmp_path / "speech.wav"
    v = _voice(dur=1.0)
    sf.write(wav, v.samples, v.sample_rate)
    return a, b, wav


def test_cli_plot(motion_files, tmp_path):
    from headmotion.cli import main

    a, b, wav = motion_files
    out = tmp_path / "p.png"
    assert main(["plot", str(a), str(b), "-o", str(out), "--audio", str(wav), "--labels", "gt,sys"]) == 0
    assert out.is_file()
    assert main(["plot", str(a), "-o", str(out), "--labels", "x,y"]) == 2  # ParameterError


def test_cli_render_grid(motion_files, tmp_path):
    from headmotion.errors import MissingDependencyError
    from headmotion.render.offscreen import create_context

    try:
        create_context().release()
    except MissingDependencyError as exc:
        pytest.skip(f"no offscreen OpenGL: {exc}")
    from headmotion.cli import main
    from headmotion.render.video import probe

    a, b, wav = motion_files
    out = tmp_path / "grid.mp4"
    rc = main(["render", str(a), str(b), "--audio", str(wav), "-o", str(out), "--size", "160x120",
               "--style", "smooth", "--labels", "truth,system"])
    assert rc == 0
    p = probe(out)
    assert "320x120" in p["video"] and p["audio"] is not None and abs(p["duration"] - 1.0) < 0.08
    assert main(["render", str(a), "-o", str(tmp_path / "x.mp4"), "--style", "cartoon"]) == 2
    assert main(["render", str(a), "-o", str(tmp_path / "x.mp4"), "--size", "161x120"]) == 2
