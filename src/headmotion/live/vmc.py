"""Head rotation out as the VMC protocol over OSC/UDP (the seeds are silent on
live transport).  Receivers: VSeeFace, Warudo, VMagicMirror, Unity's EVMC4U (default port 39539).

Per motion frame one OSC bundle (python-osc) holding::

    /VMC/Ext/OK   1                                         (a model is loaded and tracking)
    /VMC/Ext/T    time                                      (s, the frame's audio time)
    /VMC/Ext/Bone/Pos "Neck" px py pz qx qy qz qw
    /VMC/Ext/Bone/Pos "Head" px py pz qx qy qz qw

Bone rotations are *local* (relative to the parent bone), Unity-convention quaternions.

Axis mapping (tested in tests/test_live_outputs.py).  The package's frame
(:mod:`headmotion.rotations`) is right-handed with +x the speaker's left, +y up, +z forward.
Unity's is left-handed with +X the avatar's right, +Y up, +Z forward.  So a point maps as
``(X, Y, Z) = (−x, y, z)`` (a mirror in x), a rotation matrix as ``R_U = P R P`` with
``P = diag(−1, 1, 1)``, and a unit quaternion ``(w, x, y, z)`` as::

    Unity (qx, qy, qz, qw) = (x, −y, −z, w)

Checked on the named motions: positive pitch (nose down) is a positive rotation about Unity's +X
(in Unity +X rotation tilts the forward axis down); positive yaw (nose to the speaker's left,
i.e. towards Unity −X) is a negative rotation about +Y; positive roll (top of the head to the
speaker's right shoulder, i.e. towards +X) is a negative rotation about +Z.

Neck share: the head's rotation relative to the torso is split between the Neck bone and the Head
bone (its child).  Both take the same axis: Neck gets ``share · θ`` and Head ``(1 − share) · θ``,
so Neck ∘ Head is exactly the frame's rotation.  Default: the share the BVH and glTF writers use,
:data:`headmotion.io.bvh.DEFAULT_NECK_SHARE` (0.93, what the neck chain carries in real mocap,
measured by :mod:`headmotion.motion.neck_share` on a ZEGGS take), so every output of the package
splits the head the same way; 0 sends everything on Head.  Bone positions are the local offsets of a
typical VRM humanoid (Neck 0.10 m above the upper chest, Head 0.08 m above the neck); receivers
that do not synchronise bone positions ignore them.

Library: python-osc (pure Python, maintained; OSC 1.0 bundles and a threaded UDP server used by
the tests).
"""

from __future__ import annotations

import socket

import numpy as np

from ..errors import NetworkError, ParameterError

VMC_DEFAULT_PORT = 39539
NECK_OFFSET = (0.0, 0.10, 0.0)
HEAD_OFFSET = (0.0, 0.08, 0.0)


def parse_host_port(spec: str, *, default_port: int | None = None, what: str = "--vmc") -> tuple[str, int]:
    """``"HOST:PORT"`` (or ``":PORT"``, ``"PORT"``, ``"HOST"`` with a default port) → ``(host, port)``."""
    s = str(spec).strip()
    if s.isdigit():
        host, port = "", s
    elif ":" in s:
        host, port = s.rsplit(":", 1)
    else:
        host, port = s, ""
    host = host.strip("[]") or "127.0.0.1"
    if not port:
        if default_port is None:
            raise NetworkError(f"{what} {spec!r}: expected HOST:PORT, e.g. 127.0.0.1:{VMC_DEFAULT_PORT}")
        port = str(default_port)
    if not port.isdigit() or not 0 <= int(port) <= 65535:
        raise NetworkError(f"{what} {spec!r}: the port must be a number from 0 to 65535; got {port!r}")
    return host, int(port)


def package_quat_to_unity(quat_xyzw: np.ndarray) -> np.ndarray:
    """Package-frame quaternions ``(..., 4)`` as ``(x, y, z, w)`` → Unity ``(qx, qy, qz, qw)``."""
    q = np.array(quat_xyzw, dtype=np.float64)
    q[..., 1] *= -1.0
    q[..., 2] *= -1.0
    return q


def vmc_bone_quats(rotvec: np.ndarray, neck_share: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Unity-convention local quaternions ``(n, 4)`` (x, y, z, w) of Neck and Head for package
    rotation vectors ``(n, 3)``."""
    from scipy.spatial.transform import Rotation

    if neck_share is None:
        from ..io.bvh import DEFAULT_NECK_SHARE

        neck_share = DEFAULT_NECK_SHARE
    if not 0.0 <= float(neck_share) <= 1.0:
        raise ParameterError(f"neck_share must be between 0 and 1; got {neck_share}")
    rv = np.asarray(rotvec, dtype=np.float64).reshape(-1, 3)
    neck = Rotation.from_rotvec(neck_share * rv).as_quat()          # scipy: (x, y, z, w)
    head = Rotation.from_rotvec((1.0 - neck_share) * rv).as_quat()
    return package_quat_to_unity(neck), package_quat_to_unity(head)


class VmcSender:
    """Sends frame records (:func:`headmotion.live.frames.frame_records`) as VMC bundles.

    Parameters
    ----------
    host, port : the receiver (VSeeFace etc. listen on 39539 by default)
    neck_share : float in [0, 1], see the module docstring
    local_port : int, optional, bind the sending socket to this local UDP port (some setups
        filter by source port); a port in use raises :class:`~headmotion.errors.NetworkError`
    """

    name = "VMC"

    def __init__(self, host: str, port: int, *, neck_share: float | None = None, local_port: int | None = None):
        from pythonosc.udp_client import UDPClient

        if neck_share is None:
            from ..io.bvh import DEFAULT_NECK_SHARE

            neck_share = DEFAULT_NECK_SHARE
        self.neck_share = float(neck_share)
        if not 0.0 <= self.neck_share <= 1.0:
            raise ParameterError(f"neck_share must be between 0 and 1; got {neck_share}")
        try:
            infos = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)
        except (socket.gaierror, OSError) as exc:
            raise NetworkError(f"--vmc {host}:{port}: cannot resolve the host ({exc})") from None
        self.address = infos[0][4][:2]
        self.client = UDPClient(host, int(port), family=infos[0][0])
        if local_port is not None:
            try:
                self.client._sock.bind(("", int(local_port)))
            except OSError as exc:
                self.client._sock.close()
                raise NetworkError(f"--vmc: cannot send from local UDP port {local_port}: {exc.strerror or exc} "
                                   "(another program is using it?)") from None
        self.sent = 0
        self.errors = 0

    def send(self, records: list[dict]) -> None:
        from pythonosc.osc_bundle_builder import IMMEDIATELY, OscBundleBuilder
        from pythonosc.osc_message_builder import OscMessageBuilder

        if not records:
            return
        rv = np.array([r["rotvec"] for r in records], dtype=np.float64)
        neck, head = vmc_bone_quats(rv, self.neck_share)
        for r, qn, qh in zip(records, neck, head):
            bundle = OscBundleBuilder(IMMEDIATELY)
            for addr, args in (("/VMC/Ext/OK", [1]), ("/VMC/Ext/T", [float(r["time"])]),
                               ("/VMC/Ext/Bone/Pos", ["Neck", *map(float, NECK_OFFSET), *map(float, qn)]),
                               ("/VMC/Ext/Bone/Pos", ["Head", *map(float, HEAD_OFFSET), *map(float, qh)])):
                m = OscMessageBuilder(address=addr)
                for a in args:
                    m.add_arg(a)
                bundle.add_content(m.build())
            try:
                self.client.send(bundle.build())
                self.sent += 1
            except OSError:  # e.g. ICMP port unreachable reported on a later send: keep going
                self.errors += 1

    def close(self) -> None:
        try:
            self.client._sock.close()
        except OSError:
            pass


__all__ = ["VmcSender", "vmc_bone_quats", "package_quat_to_unity",
           "parse_host_port", "VMC_DEFAULT_PORT"]
