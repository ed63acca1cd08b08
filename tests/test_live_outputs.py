"""Live inputs, session and outputs on loopback: a real OSC server
receives VMC Head/Neck bones whose rotation equals the JSON line's, real WebSocket clients
receive the same frames, the microphone path runs on an injected device, and bad input gives
clear messages while the others keep being served.  Every server and loop is bounded in time."""

from __future__ import annotations

import io
import json
import socket
import threading
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from headmotion.errors import AudioDeviceError, NetworkError
from headmotion.live.frames import JsonLinesOutput, frame_records
from headmotion.live.inputs import FileSource, MicSource, open_input, PcmSource
from headmotion.live.session import LiveSession
from headmotion.live.vmc import (
    VmcSender,
    package_quat_to_unity,
    parse_host_port,
    vmc_bone_quats,
)
from conftest import OLD_TWS_MODEL

from headmotion.live.websocket import WebSocketBroadcaster
from headmotion.types import Motion

pytestmark = pytest.mark.timeout(120)
SR = 16000
#: a causal model at 100 fps (the former shipped streaming model, tws-hier): the outputs' plumbing at
#: a high frame rate; the shipped stream model (motion-match, 25 fps) is covered by the serve and CLI tests
MODEL = OLD_TWS_MODEL


class FakeStream:
    """A motion stream with a known answer: one frame per 160 samples, yaw = frame index · 0.01."""

    latency_ms = 0.0

    def __init__(self):
        self.n = 0
        self.buf = 0

    def push(self, x):
        self.buf += len(x)
        k = self.buf // 160
        self.buf -= 160 * k
        rv = np.zeros((k, 3))
        rv[:, 1] = 0.01 * np.arange(self.n, self.n + k)
        rv[:, 0] = 0.2
        self.n += k
        return Motion(rv, 100.0)

    def flush(self):
        return Motion(np.zeros((0, 3)), 100.0)


# -- axis mapping --------------------------------------------------------------------------------
def test_unity_axis_mapping_of_named_motions():
    # package: +pitch nose down (about +x), +yaw nose to the speaker's left, +roll top to the right
    th = 0.3
    for axis, unity_axis, sign in ((0, 0, +1), (1, 1, -1), (2, 2, -1)):
        rv = np.zeros(3)
        rv[axis] = th
        q = package_quat_to_unity(Rotation.from_rotvec(rv).as_quat())
        expect = np.zeros(4)
        expect[unity_axis] = sign * np.sin(th / 2)
        expect[3] = np.cos(th / 2)
        np.testing.assert_allclose(q, expect, atol=1e-12)
    # as a matrix: R_U = P R P, P = diag(-1, 1, 1) (the mirror x -> -x of the two frames)
    rv = np.array([0.2, -0.4, 0.1])
    P = np.diag([-1.0, 1.0, 1.0])
    ru = Rotation.from_quat(package_quat_to_unity(Rotation.from_rotvec(rv).as_quat())).as_matrix()
    np.testing.assert_allclose(ru, P @ Rotation.from_rotvec(rv).as_matrix() @ P, atol=1e-12)
    # the nose (+Z forward in both) goes down (-Y) for positive pitch, to -X (the speaker's left) for yaw
    nose = np.array([0.0, 0.0, 1.0])
    down = Rotation.from_quat(package_quat_to_unity(Rotation.from_rotvec([th, 0, 0]).as_quat())).apply(nose)
    left = Rotation.from_quat(package_quat_to_unity(Rotation.from_rotvec([0, th, 0]).as_quat())).apply(nose)
    assert down[1] < 0 and left[0] < 0


def test_neck_and_head_compose_to_the_rotation():
    rv = np.array([[0.3, -0.2, 0.1], [0.0, 0.0, 0.0]])
    neck, head = vmc_bone_quats(rv, 0.3)
    P = np.diag([-1.0, 1.0, 1.0])
    for i in range(2):
        total = Rotation.from_quat(neck[i]) * Rotation.from_quat(head[i])
        np.testing.assert_allclose(P @ total.as_matrix() @ P, Rotation.from_rotvec(rv[i]).as_matrix(), atol=1e-12)
        assert Rotation.from_quat(neck[i]).magnitude() == pytest.approx(0.3 * np.linalg.norm(rv[i]))


def test_parse_host_port():
    assert parse_host_port("127.0.0.1:39539") == ("127.0.0.1", 39539)
    assert parse_host_port(":9000") == ("127.0.0.1", 9000)
    assert parse_host_port("9000") == ("127.0.0.1", 9000)
    with pytest.raises(NetworkError, match="port must be a number"):
        parse_host_port("localhost:abc")
    with pytest.raises(NetworkError, match="HOST:PORT"):
        parse_host_port("localhost")


# -- OSC / VMC on loopback -----------------------------------------------------------------------
def _osc_server():
    """An OSC server recording what it receives in arrival order (one thread: a threading server
    handles each bundle in its own thread, and under load appends them out of order)."""
    from pythonosc.dispatcher import Dispatcher
    from pythonosc.osc_server import BlockingOSCUDPServer

    got = []
    d = Dispatcher()
    d.map("/VMC/Ext/Bone/Pos", lambda _addr, *args: got.append((time.monotonic(), args)))
    d.map("/VMC/Ext/T", lambda _addr, *args: got.append((time.monotonic(), ("T",) + args)))
    srv = BlockingOSCUDPServer(("127.0.0.1", 0), d)
    th = threading.Thread(target=srv.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
    th.start()
    return srv, th, got


@pytest.mark.shared
def test_session_default_model_to_osc_websocket_and_json_lines(shared_data, tmp_path):
    """The shipped model, a real speech file paced in real time: the OSC server gets Head and Neck
    at the model's frame rate with unit quaternions equal to the JSON line's rotation, and two
    WebSocket clients get the same frames; one disconnects early and the other keeps receiving."""
    import soundfile as sf
    from websockets.exceptions import ConnectionClosed
    from websockets.sync.client import connect

    from headmotion.io import load_audio
    from headmotion.systems.base import load_model

    a = load_audio(shared_data / "speech" / "jfk.flac")
    wav = tmp_path / "s.wav"
    sf.write(wav, a.samples[: 3 * a.sample_rate], a.sample_rate)  # 3 s at the file's rate (resampled on the stream)
    model = load_model(MODEL)
    srv, th, got = _osc_server()
    out = io.StringIO()
    ws = WebSocketBroadcaster("127.0.0.1", 0).start()
    received = {"a": [], "b": []}

    def client(key, limit):
        with connect(f"ws://127.0.0.1:{ws.port}", open_timeout=5) as c:
            while len(received[key]) < limit:
                try:
                    received[key].append(json.loads(c.recv(timeout=8)))
                except (TimeoutError, ConnectionClosed):   # the server closes at the end
                    return

    ta = threading.Thread(target=client, args=("a", 10 ** 6), daemon=True)
    tb = threading.Thread(target=client, args=("b", 20), daemon=True)   # leaves after 20 frames
    ta.start(); tb.start()
    t_end = time.monotonic() + 5
    while ws.n_clients < 2 and time.monotonic() < t_end:
        time.sleep(0.01)
    assert ws.n_clients == 2
    vmc = VmcSender("127.0.0.1", srv.server_address[1], neck_share=0.3)
    try:
        src = FileSource(wav, out_rate=int(model.sample_rate_), realtime=True)
        stats = LiveSession(src, model.stream(seed=0), [JsonLinesOutput(out), vmc, ws], fps=100).run(max_seconds=30)
        time.sleep(0.3)
    finally:
        ws.close()
        ta.join(10); tb.join(10)
        srv.shutdown(); srv.server_close(); th.join(5)
        vmc.close()
    lines = [json.loads(s) for s in out.getvalue().splitlines()]
    assert len(lines) == stats["frames"] == 300
    assert [r["frame"] for r in lines] == list(range(300))
    lat = stats["latency"]
    assert lat["frames"] == 300 and lat["median_ms"] > 0
    # WebSocket: the surviving client got every frame, identical to the JSON lines; the other left
    assert received["a"] == lines
    assert received["b"] == lines[:20]
    # OSC: one Head and one Neck per frame, unit quaternions; Neck ∘ Head == the line's rotation
    heads = [(t, a) for t, a in got if a[0] == "Head"]
    necks = [(t, a) for t, a in got if a[0] == "Neck"]
    assert len(heads) == len(necks) == 300
    P = np.diag([-1.0, 1.0, 1.0])
    for (_, h), (_, n), line in zip(heads, necks, lines):
        qh, qn = np.array(h[4:8]), np.array(n[4:8])
        assert abs(np.linalg.norm(qh) - 1) < 1e-5 and abs(np.linalg.norm(qn) - 1) < 1e-5
        total = P @ (Rotation.from_quat(qn) * Rotation.from_quat(qh)).as_matrix() @ P
        np.testing.assert_allclose(total, Rotation.from_rotvec(line["rotvec"]).as_matrix(), atol=2e-5)
    # at the model's frame rate: 300 frames over the 3 s of paced audio (+ the flush at the end)
    span = heads[-1][0] - heads[0][0]
    assert 2.0 < span < 3.6, span


def test_vmc_local_port_in_use_is_a_clear_error():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("", 0))
    port = s.getsockname()[1]
    try:
        with pytest.raises(NetworkError, match=f"local UDP port {port}.*another program"):
            VmcSender("127.0.0.1", 39539, local_port=port)
    finally:
        s.close()


def test_websocket_port_in_use_is_a_clear_error():
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.bind(("127.0.0.1", 0))
    s.listen(1)
    port = s.getsockname()[1]
    try:
        with pytest.raises(NetworkError, match=f"127.0.0.1:{port}.*another program"):
            WebSocketBroadcaster("127.0.0.1", port).start()
    finally:
        s.close()


def test_websocket_client_that_disconnects_does_not_stop_the_others():
    from websockets.sync.client import connect

    with WebSocketBroadcaster("127.0.0.1", 0) as ws, \
            connect(f"ws://127.0.0.1:{ws.port}", open_timeout=5) as a, \
            connect(f"ws://127.0.0.1:{ws.port}", open_timeout=5) as b:
        t_end = time.monotonic() + 5
        while ws.n_clients < 2 and time.monotonic() < t_end:
            time.sleep(0.01)
        ws.send(frame_records(np.zeros((2, 3)), 100, 0))
        assert json.loads(a.recv(timeout=5))["frame"] == 0
        b.close()                                        # b leaves abruptly
        ws.send(frame_records(np.full((3, 3), 0.1), 100, 2))
        got = [json.loads(a.recv(timeout=5))["frame"] for _ in range(4)]
        assert got == [1, 2, 3, 4]
        t_end = time.monotonic() + 5
        while ws.n_clients > 1 and time.monotonic() < t_end:
            ws.send(frame_records(np.zeros((1, 3)), 100, 99))
            time.sleep(0.05)
        assert ws.n_clients == 1


# -- inputs ------------------------------------------------------------------------------------
def test_pcm_stream_that_stops_mid_sample():
    x = (np.sin(np.arange(1600) / 10) * 10000).astype("<i2").tobytes() + b"\x01"
    msgs = []
    src = PcmSource(io.BytesIO(x), sample_rate=SR, out_rate=SR, on_message=msgs.append)
    out = io.StringIO()
    stats = LiveSession(src, FakeStream(), [JsonLinesOutput(out)], fps=100).run(max_seconds=10)
    assert stats["frames"] == 10
    assert src.dropped_bytes == 1
    assert len(msgs) == 1 and "middle of a 16-bit sample" in msgs[0] and "1 byte" in msgs[0]


def test_pcm_resampled_on_the_stream_keeps_the_duration():
    sr_in = 44100
    t = np.arange(2 * sr_in) / sr_in
    x = (0.3 * np.sin(2 * np.pi * 200 * t) * 32767).astype("<i2").tobytes()
    src = PcmSource(io.BytesIO(x), sample_rate=sr_in, out_rate=SR, chunk_ms=10)
    y = np.concatenate(list(src))
    assert abs(len(y) - 2 * SR) <= 2
    spec = np.abs(np.fft.rfft(y[SR // 2: SR // 2 + SR]))
    assert abs(np.argmax(spec) - 200) <= 1   # 1 Hz bins: the tone is still at 200 Hz


@pytest.mark.slow
def test_minutes_of_silence_through_the_default_model():
    from headmotion.systems.base import load_model

    model = load_model(MODEL)
    z = np.zeros(2 * 60 * SR, dtype="<i2").tobytes()     # two minutes, not paced
    out = io.StringIO()
    stats = LiveSession(PcmSource(io.BytesIO(z), sample_rate=SR, out_rate=SR),
                        model.stream(seed=0), [JsonLinesOutput(out)], fps=100).run(max_seconds=90)
    assert stats["frames"] == 12000
    rv = np.array([json.loads(s)["rotvec"] for s in out.getvalue().splitlines()[-100:]])
    assert np.all(np.isfinite(rv)) and np.abs(rv).max() < 1.0


class _FakeStreamCtx:
    def __init__(self, callback, samplerate, blocksize, n_blocks=50, **kw):
        self.cb, self.sr, self.block, self.n = callback, samplerate, blocksize, n_blocks
        self.active = False
        self.kw = kw

    def __enter__(self):
        self.active = True

        def run():
            t = 0
            for _ in range(self.n):
                k = np.arange(t, t + self.block)
                x = (0.3 * np.sin(2 * np.pi * 150 * k / self.sr)).astype(np.float32)[:, None]
                self.cb(x, self.block, None, None)
                t += self.block
                time.sleep(0.002)
            self.active = False

        self.th = threading.Thread(target=run, daemon=True)
        self.th.start()
        return self

    def __exit__(self, *a):
        self.th.join(5)
        self.active = False


class FakeSounddevice:
    """A stand-in for the sounddevice module: one output-only and one input device."""

    def __init__(self, devices=None):
        self.devices = devices if devices is not None else [
            {"name": "HDMI out", "max_input_channels": 0, "default_samplerate": 48000.0},
            {"name": "USB Microphone", "max_input_channels": 1, "default_samplerate": 48000.0}]
        self.default = type("D", (), {"device": (1, 0)})()
        self.opened = None

    def query_devices(self):
        return self.devices

    def InputStream(self, **kw):
        self.opened = kw
        return _FakeStreamCtx(**kw)


def test_mic_with_injected_device_streams_resampled_audio():
    sd = FakeSounddevice()
    src = open_input("mic", out_rate=SR, device="usb", sd=sd)
    assert src.index == 1 and "USB Microphone" in src.name
    stats = LiveSession(src, FakeStream(), [], fps=100).run(max_seconds=20)
    assert sd.opened["device"] == 1 and sd.opened["samplerate"] == 48000 and sd.opened["blocksize"] == 480
    assert src.t0 is not None and stats["latency"]["frames"] == stats["frames"]
    # 50 blocks of 10 ms at 48 kHz → ≈ 0.5 s at 16 kHz, minus what the resampler still holds
    assert 35 <= stats["frames"] <= 50


def test_mic_errors_are_clear():
    with pytest.raises(AudioDeviceError, match="no audio input device"):
        MicSource(None, out_rate=SR, sd=FakeSounddevice(devices=[{"name": "out", "max_input_channels": 0}]))
    with pytest.raises(AudioDeviceError, match=r"--device 7: .*1: USB Microphone"):
        MicSource(7, out_rate=SR, sd=FakeSounddevice())
    with pytest.raises(AudioDeviceError, match="no input device name contains"):
        MicSource("webcam", out_rate=SR, sd=FakeSounddevice())


def test_mic_without_portaudio_is_a_clear_error(monkeypatch):
    import builtins

    real = builtins.__import__

    def fake_import(name, *a, **k):
        if name == "sounddevice":
            raise OSError("PortAudio library not found")
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", fake_import)
    with pytest.raises(AudioDeviceError, match="PortAudio library"):
        MicSource(None, out_rate=SR)


def test_realtime_file_is_paced(tmp_path):
    import soundfile as sf

    wav = tmp_path / "t.wav"
    sf.write(wav, np.zeros(SR // 2, np.float32), SR)
    t0 = time.monotonic()
    stats = LiveSession(FileSource(wav, out_rate=SR, realtime=True), FakeStream(), [], fps=100).run(max_seconds=10)
    took = time.monotonic() - t0
    assert stats["frames"] == 50 and 0.45 < took < 2.0
    assert 0 <= stats["latency"]["median_ms"] < 200


def test_failing_output_is_dropped_and_the_others_continue():
    class Broken:
        name = "broken"

        def send(self, records):
            raise OSError("pipe closed")

        def close(self):
            pass

    msgs = []
    out = io.StringIO()
    z = np.zeros(SR, dtype="<i2").tobytes()
    stats = LiveSession(PcmSource(io.BytesIO(z), sample_rate=SR, out_rate=SR), FakeStream(),
                        [Broken(), JsonLinesOutput(out)], fps=100, on_message=msgs.append).run(max_seconds=10)
    assert stats["frames"] == 100 and len(out.getvalue().splitlines()) == 100
    assert len(msgs) == 1 and "broken output failed" in msgs[0]


# -- the one call the stream command makes -------------------------------------------------------
def test_stream_live_pcm_on_stdin_with_the_streaming_default_model():
    from headmotion.live.session import stream_live
    from headmotion.systems.base import load_model

    model = load_model(MODEL)
    t = np.arange(2 * 44100) / 44100
    pcm = (0.2 * np.sin(2 * np.pi * 140 * t) * 32767).astype("<i2").tobytes()
    out, msgs = io.StringIO(), []
    stats = stream_live(model, input="-", sample_rate=44100, stdin=io.BytesIO(pcm), json_stream=out,
                        on_message=msgs.append, max_seconds=60)
    lines = [json.loads(s) for s in out.getvalue().splitlines()]
    assert len(lines) == stats["frames"] and abs(len(lines) - 200) <= 1
    assert set(lines[0]) == {"frame", "time", "rotvec", "pitch_yaw_roll_deg"}
    assert lines[-1]["time"] == pytest.approx((len(lines) - 1) / 100)
    assert "streaming with tws-hier: stdin" in msgs[0] and "algorithmic latency" in msgs[0]


def test_stream_live_refuses_a_non_causal_model_and_bad_addresses():
    from headmotion.errors import ParameterError
    from headmotion.live.session import open_outputs, stream_live

    class Offline:
        name = "cccae"
        causal = False

    with pytest.raises(ParameterError, match="'cccae' cannot stream"):
        stream_live(Offline(), stdin=io.BytesIO(b""))
    with pytest.raises(NetworkError, match="--websocket 'nowhere'"):
        open_outputs(websocket="nowhere")
    with pytest.raises(NetworkError, match="--vmc.*port must be a number"):
        open_outputs(vmc="127.0.0.1:http")


def test_a_file_at_full_speed_is_resampled_as_synth_does_paced_with_low_latency(tmp_path):
    """A 48 kHz file streamed at full speed arrives at 16 kHz exactly as ``synth`` resamples it
    (soxr HQ; its stream resampler gives the one-shot samples), so ``stream --input FILE`` gives
    ``synth``'s frames; paced (``--realtime``) it keeps the low-latency resampler."""
    import soundfile as sf

    from headmotion.io.audio import resample

    t = np.arange(48000 * 2) / 48000.0
    x = (0.3 * np.sin(2 * np.pi * 220.0 * t) * (1 + np.sin(2 * np.pi * 3.0 * t))).astype(np.float32)
    wav = tmp_path / "tone48k.wav"
    sf.write(wav, x, 48000, subtype="FLOAT")
    got = np.concatenate(list(open_input(str(wav), out_rate=SR)))
    want = resample(x, 48000, SR)
    assert len(got) == len(want)
    np.testing.assert_array_equal(got, want)
    paced = FileSource(wav, out_rate=SR, realtime=True, clock=lambda: 0.0, sleep=lambda _s: None)
    assert paced.resampler._rs is not None and not np.array_equal(np.concatenate(list(paced)), want)


def test_stream_live_settles_at_the_end():
    """``settle_s`` 0.4 at 100 fps: the same frames as without it, then 40 more that end at the
    rest pose plus the offset (2° of pitch)."""
    from headmotion.live.session import stream_live
    from headmotion.rotations import pitch_yaw_roll_to_rotvec
    from headmotion.synthesis import Controls
    from headmotion.systems.base import load_model

    model = load_model(MODEL)
    t = np.arange(16000) / 16000
    pcm = (0.2 * np.sin(2 * np.pi * 140 * t) * 32767).astype("<i2").tobytes()
    runs = []
    for settle in (0.0, 0.4):
        out = io.StringIO()
        stream_live(model, input="-", sample_rate=16000, stdin=io.BytesIO(pcm), json_stream=out,
                    on_message=print, max_seconds=60, settle_s=settle,
                    controls=Controls.parse(offset_degrees="2,0,0"))
        runs.append(np.array([json.loads(s)["rotvec"] for s in out.getvalue().splitlines()]))
    plain, settled = runs
    assert len(settled) == len(plain) + 40
    np.testing.assert_array_equal(settled[:len(plain)], plain)
    np.testing.assert_allclose(settled[-1], pitch_yaw_roll_to_rotvec(np.radians(2.0), 0.0, 0.0).reshape(3), atol=1e-6)
