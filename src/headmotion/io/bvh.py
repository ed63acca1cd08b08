"""BVH (Biovision Hierarchy) reading and writing (thesis §2.2.3).

Reading
-------
Any skeleton: the HIERARCHY is parsed (ROOT/JOINT/End Site, OFFSET, CHANNELS in any order and
number — 6-channel joints included), each joint's Euler order is taken from the order of its
rotation channels.  BVH's convention: for ``CHANNELS ... Zrotation Xrotation Yrotation`` the local
rotation is ``Rz @ Rx @ Ry`` (intrinsic ``"ZXY"`` in scipy notation), angles in degrees, and
``v_parent = R_local @ v_child``; rest rotations are the identity (offsets only).

**Head relative to torso = the neck chain composed.**  The head joint is the one named by
``head=`` or found by name (``Head``, ``head``, ``mixamorig:Head``, …; otherwise a name containing
"head" that is not an end/top/nub joint).  The reference joint ``relative_to=`` defaults to the
nearest ancestor of the head whose name looks like a torso joint (spine / chest / torso / thorax,
e.g. ``Spine3`` in the ZEGGS skeleton, ``Spine2`` in Mixamo's, ``Chest`` in CMU's); failing that
the root.  The head's rotation is the product of the local rotations of every joint on the chain
from the reference joint (exclusive) to the head (inclusive), e.g. ``R_Neck @ R_Neck1 @ R_Head``:
the head's orientation in the chest's frame.  That equals ``R_chest_global^T @ R_head_global``.

Axes: BVH files are almost always Y-up with the character facing +Z, so the character's left is
+x — exactly our convention (+x left, +y up, +z forward, :mod:`headmotion.rotations`).  Files made
otherwise can be read with ``up="+z", forward="-y"`` etc.; the rotation is then ``M R M^T``
(:func:`headmotion.io._mocap.axis_matrix`).

Writing
-------
A minimal skeleton Hips → Spine → Neck → Head (→ End Site), Y-up, facing +Z, offsets in cm
(hips 95 cm above the floor, spine 10 cm, neck 45 cm above the spine joint, head 10 cm above the
neck, head top 18 cm).  The root has 6 channels (position, then rotation); the others 3.  Channel
order ``"ZXY"`` (default; what Blender and MotionBuilder write) or ``"YXZ"``, angles in degrees
with 6 decimals; Frame Time = 1/fps.  The rotation is spread over **Neck** and **Head**: with
``neck_share=s`` the neck holds ``exp(s·r)`` and the head the rest, so neck ∘ head is exactly the
motion.  The default ``s = 0.93`` (:data:`DEFAULT_NECK_SHARE`) is what the ZEGGS mocap take shows
(:mod:`headmotion.motion.neck_share`: its Neck and Neck1 make 93% of the head's movement);
``neck_share=0`` puts it all on the head joint.  Re-reading
gives the same rotations (< 1e-6 rad).  The root stays still (``Motion.translation`` is not
written).  Blender 3.4's ``import_anim.bvh`` reads it and shows the same head rotation within
1e-5° (tests/test_io_motion_blender.py).

Libraries considered: ``bvh`` (PyPI) only tokenises and has no rotation maths; ``pymo`` pulls in
pandas and scikit-learn; Blender's importer is GPL and needs Blender.  The format is small, so it
is parsed here with scipy's rotations.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from typing import TYPE_CHECKING

import numpy as np

from .. import quaternions
from ..errors import FormatError, NoHeadError, ParameterError
from ..types import Motion
from ._limits import FPS_RANGE, parse_count, read_text
from ._mocap import axis_matrix

if TYPE_CHECKING:  # scipy.spatial is imported where BVH files are read, not to write one
    from scipy.spatial.transform import Rotation
from .atomic import atomic_open

_TORSO_WORDS = ("spine", "chest", "torso", "thorax", "back")
_HEAD_EXCLUDE = ("end", "top", "nub", "site", "tip")


@dataclass
class Joint:
    name: str
    parent: int | None
    offset: np.ndarray
    channels: list[str] = field(default_factory=list)
    start: int = 0  # index of the first channel in a frame line

    @property
    def rotation_order(self) -> str:
        return "".join(c[0].upper() for c in self.channels if c.lower().endswith("rotation"))

    def rotation_columns(self) -> list[int]:
        return [self.start + i for i, c in enumerate(self.channels) if c.lower().endswith("rotation")]

    def position_columns(self) -> list[int]:
        """Columns of X, Y, Z position in that order (empty if the joint has none)."""
        cols = {c[0].upper(): self.start + i for i, c in enumerate(self.channels)
                if c.lower().endswith("position")}
        return [cols[a] for a in "XYZ"] if len(cols) == 3 else []


@dataclass
class BVHFile:
    joints: list[Joint]
    frames: np.ndarray  # (T, n_channels), as written
    frame_time: float
    path: Path

    @property
    def fps(self) -> float:
        """``1 / Frame Time``, snapped to a whole number when within 1e-6 of one (files store
        Frame Time rounded, e.g. 0.0333333 for 30 fps)."""
        f = 1.0 / self.frame_time
        return float(round(f)) if abs(f - round(f)) < 1e-6 * f else f

    @property
    def names(self) -> list[str]:
        return [j.name for j in self.joints]

    def index(self, name: str) -> int:
        return self.names.index(name)

    def local_rotations(self, j: int) -> Rotation:
        from scipy.spatial.transform import Rotation

        joint = self.joints[j]
        cols = joint.rotation_columns()
        if not cols:
            return Rotation.identity(len(self.frames))
        return Rotation.from_euler(joint.rotation_order, self.frames[:, cols], degrees=True)

    def chain(self, ancestor: int, child: int) -> list[int]:
        """Joints from just below ``ancestor`` down to ``child`` (inclusive)."""
        out = []
        j = child
        while j is not None and j != ancestor:
            out.append(j)
            j = self.joints[j].parent
        if j != ancestor:
            raise ParameterError(
                f"{self.path}: joint {self.joints[ancestor].name!r} is not an ancestor of "
                f"{self.joints[child].name!r}"
            )
        return out[::-1]


def _num(tok: str, path, line: int) -> float:
    try:
        return float(tok)
    except ValueError:
        raise FormatError(f"expected a number, found {tok!r}", path=path, line=line) from None


def read_bvh_file(path) -> BVHFile:
    """Parse a BVH file into joints and the raw channel matrix (no rotation maths).

    The HIERARCHY section (:func:`_parse_hierarchy`), the MOTION header (:func:`_parse_motion_header`)
    and the frame lines (:func:`_parse_frames`) are read in turn; each checks what it reads before
    anything is allocated and raises :class:`~headmotion.errors.FormatError` naming the line.
    """
    path = Path(path)
    text = read_text(path, what="BVH file", errors="replace")
    lines = text.splitlines()
    if not text.strip():
        raise FormatError("file is empty (expected a BVH file starting with HIERARCHY)", path=path)
    i = 0
    while i < len(lines) and not lines[i].strip():
        i += 1
    if lines[i].strip().upper() != "HIERARCHY":
        raise FormatError(f"expected 'HIERARCHY' on the first line, found {lines[i].strip()[:40]!r}",
                          path=path, line=i + 1)
    joints, n_channels, i = _parse_hierarchy(lines, i + 1, path)
    n_frames, frame_time, frames_line, i = _parse_motion_header(lines, i, path)
    if n_channels == 0:
        raise FormatError("no joint has CHANNELS, so the frames hold nothing", path=path)
    data = _parse_frames(lines, i, n_frames, n_channels, frames_line, path)
    return BVHFile(joints=joints, frames=data, frame_time=frame_time, path=path)


def _parse_hierarchy(lines: list[str], i: int, path: Path) -> tuple[list[Joint], int, int]:
    """The joints of the HIERARCHY section starting at line index ``i``, the number of channels,
    and the index of the line after ``MOTION``."""
    joints: list[Joint] = []
    stack: list[int | None] = []  # joint index per open brace (None for End Site)
    pending: Joint | None = None
    pending_end = False
    n_channels = 0
    while i < len(lines):
        raw = lines[i].strip()
        ln = i + 1
        i += 1
        if not raw:
            continue
        tok = raw.split()
        key = tok[0].upper()
        if key in ("ROOT", "JOINT"):
            if len(tok) < 2:
                raise FormatError(f"{tok[0]} without a name", path=path, line=ln)
            parent = next((s for s in reversed(stack) if s is not None), None) if stack else None
            if key == "JOINT" and not stack:
                raise FormatError("JOINT outside any ROOT", path=path, line=ln)
            pending = Joint(name=" ".join(tok[1:]), parent=parent, offset=np.zeros(3))
            joints.append(pending)
            pending_end = False
        elif key == "END":
            pending_end = True
            pending = None
        elif key == "{":
            if pending_end:
                stack.append(None)
                pending_end = False
            elif pending is not None:
                stack.append(len(joints) - 1)
                pending = None
            else:
                raise FormatError("'{' without a joint", path=path, line=ln)
        elif key == "}":
            if not stack:
                raise FormatError("unbalanced '}'", path=path, line=ln)
            stack.pop()
        elif key == "OFFSET":
            if len(tok) != 4:
                raise FormatError(f"OFFSET needs 3 numbers, found {len(tok) - 1}", path=path, line=ln)
            if stack and stack[-1] is not None:
                joints[stack[-1]].offset = np.array([_num(t, path, ln) for t in tok[1:]])
        elif key == "CHANNELS":
            if not stack or stack[-1] is None:
                raise FormatError("CHANNELS outside a joint", path=path, line=ln)
            j = joints[stack[-1]]
            j.channels = _channels(tok, path, ln)
            j.start = n_channels
            n_channels += len(j.channels)
        elif key == "MOTION":
            break
        else:
            raise FormatError(f"unexpected {tok[0]!r} in HIERARCHY", path=path, line=ln)
    else:
        raise FormatError("no MOTION section", path=path)
    if stack:
        raise FormatError("HIERARCHY has unclosed braces", path=path)
    if not joints:
        raise FormatError("HIERARCHY defines no joints", path=path)
    return joints, n_channels, i


def _channels(tok: list[str], path: Path, ln: int) -> list[str]:
    """The channel names of a ``CHANNELS n name...`` line, checked (count, known names, no repeats)."""
    if len(tok) < 2:
        raise FormatError("CHANNELS needs a count", path=path, line=ln)
    n = parse_count(tok[1], path=path, line=ln, what="the CHANNELS count", maximum=6)
    chans = tok[2:]
    if len(chans) != n:
        raise FormatError(f"CHANNELS says {n} but lists {len(chans)}", path=path, line=ln)
    valid = {f"{a}{k}" for a in "XYZ" for k in ("position", "rotation")}
    for c in chans:
        if c[:1].upper() + c[1:].lower() not in valid:
            raise FormatError(f"unknown channel {c!r}; expected Xposition … Zrotation",
                              path=path, line=ln)
    norm = [c[:1].upper() + c[1:].lower() for c in chans]
    if len(set(norm)) != len(norm):
        raise FormatError(f"CHANNELS lists a channel twice: {' '.join(chans)}", path=path, line=ln)
    return chans


def _parse_motion_header(lines: list[str], i: int, path: Path) -> tuple[int, float, int, int]:
    """``Frames: N`` and ``Frame Time: t`` (either order) from line index ``i``: the frame count,
    the frame time (within :data:`FPS_RANGE`), the line number of ``Frames:`` and the index of the
    first line after the header."""
    header = {}
    while i < len(lines) and len(header) < 2:
        raw = lines[i].strip()
        ln = i + 1
        i += 1
        if not raw:
            continue
        if ":" not in raw:
            raise FormatError(f"expected 'Frames:' and 'Frame Time:', found {raw[:40]!r}", path=path, line=ln)
        k, v = raw.split(":", 1)
        k = " ".join(k.lower().split())
        if k not in ("frames", "frame time"):
            raise FormatError(f"expected 'Frames:' or 'Frame Time:', found {raw[:40]!r}", path=path, line=ln)
        if k in header:
            raise FormatError(f"'{k.capitalize()}:' given twice", path=path, line=ln)
        header[k] = (v.strip(), ln)
    if len(header) < 2:
        raise FormatError("MOTION section lacks 'Frames:' / 'Frame Time:'", path=path)
    n_frames = parse_count(header["frames"][0], path=path, line=header["frames"][1], what="Frames")
    frame_time = _num(header["frame time"][0], path, header["frame time"][1])
    lo, hi = FPS_RANGE
    if not (np.isfinite(frame_time) and 1.0 / hi * (1 - 1e-6) <= frame_time <= 1.0 / lo * (1 + 1e-6)):
        raise FormatError(f"Frame Time {header['frame time'][0][:40]!r} is not a sane frame duration: "
                          f"expected {1 / hi:g} to {1 / lo:g} s ({lo:g}–{hi:g} frames/s)", path=path,
                          line=header["frame time"][1])
    return n_frames, frame_time, header["frames"][1], i


def _parse_frames(lines: list[str], i: int, n_frames: int, n_channels: int, frames_line: int,
                  path: Path) -> np.ndarray:
    """The ``(n_frames, n_channels)`` channel matrix from the frame lines starting at index ``i``;
    the line count is checked against ``Frames:`` (on line ``frames_line``) before allocating."""
    body = [(k + 1, ln) for k, ln in enumerate(lines[i:], start=i) if ln.strip()]
    if len(body) != n_frames:
        raise FormatError(
            f"'Frames: {n_frames}' but the file holds {len(body)} frame lines"
            + (" (truncated?)" if len(body) < n_frames else ""),
            path=path, line=frames_line)
    data = np.empty((n_frames, n_channels))
    for t, (ln, raw) in enumerate(body):
        vals = raw.split()
        if len(vals) != n_channels:
            raise FormatError(
                f"frame line has {len(vals)} values, expected {n_channels} (the sum of CHANNELS)",
                path=path, line=ln)
        try:
            data[t] = np.array(vals, dtype=np.float64)
        except ValueError:
            raise FormatError("frame line holds a value that is not a number", path=path, line=ln) from None
        if not np.all(np.isfinite(data[t])):
            raise FormatError("frame line holds NaN or inf (or a number too large for a float)",
                              path=path, line=ln)
    if n_frames == 0:
        raise FormatError("'Frames: 0': the file holds no motion", path=path, line=frames_line)
    return data


def _leaf_name(name: str) -> str:
    for sep in (":", "|"):
        name = name.rsplit(sep, 1)[-1]
    return name.lower()


def find_head(bvh: BVHFile, head: str | None = None) -> int:
    names = bvh.names
    if head is not None:
        if head in names:
            return names.index(head)
        low = [n.lower() for n in names]
        if head.lower() in low:
            return low.index(head.lower())
        raise NoHeadError(f"no joint named {head!r}; joints: {', '.join(names)}", path=bvh.path)
    exact = [k for k, n in enumerate(names) if _leaf_name(n) == "head"]
    if exact:
        return exact[0]
    loose = [k for k, n in enumerate(names)
             if "head" in _leaf_name(n) and not any(w in _leaf_name(n) for w in _HEAD_EXCLUDE)]
    if loose:
        return loose[0]
    raise NoHeadError(
        f"no head joint found (looked for a joint named Head/head or containing 'head'); "
        f"joints: {', '.join(names)}; pass head='NAME'", path=bvh.path)


def find_torso(bvh: BVHFile, head: int, relative_to: str | None = None) -> int | None:
    """The reference joint: ``relative_to`` by name, else the nearest torso-like ancestor of the
    head, else the root.  ``relative_to="world"`` returns None (global head rotation)."""
    if relative_to is not None:
        if relative_to.lower() == "world":
            return None
        low = [n.lower() for n in bvh.names]
        if relative_to.lower() not in low:
            raise ParameterError(f"{bvh.path}: relative_to={relative_to!r} is not a joint; joints: "
                                 f"{', '.join(bvh.names)}")
        return low.index(relative_to.lower())
    j = bvh.joints[head].parent
    root = None
    while j is not None:
        if any(w in _leaf_name(bvh.joints[j].name) for w in _TORSO_WORDS):
            return j
        root = j
        j = bvh.joints[j].parent
    return root


def load_bvh(path, *, head: str | None = None, relative_to: str | None = None,
             up: str = "+y", forward: str = "+z") -> Motion:
    """Head rotation relative to the torso from a BVH file.

    Parameters
    ----------
    path : str or Path
    head : str, optional
        Name of the head joint; found by name when omitted (:class:`NoHeadError` if none).
    relative_to : str, optional
        Name of the torso joint the rotation is relative to (default: the nearest
        spine/chest-like ancestor of the head; ``"world"`` for the global head rotation).
    up, forward : str
        The file's up axis and the way the character faces (default ``+y``, ``+z``).

    Returns
    -------
    Motion with ``rotvec (T, 3)`` at ``1 / Frame Time`` fps; ``meta`` names the joints used.
    """
    bvh = read_bvh_file(path)
    h = find_head(bvh, head)
    ref = find_torso(bvh, h, relative_to)
    if ref is None:
        chain = _path_from_root(bvh, h)
    else:
        chain = bvh.chain(ref, h)
    from scipy.spatial.transform import Rotation

    rot = Rotation.identity(len(bvh.frames))
    for j in chain:
        rot = rot * bvh.local_rotations(j)
    m = axis_matrix(up=up, forward=forward)
    mat = m @ rot.as_matrix() @ m.T
    rotvec = Rotation.from_matrix(mat).as_rotvec()
    meta = {
        "source": str(path), "format": "bvh", "head_joint": bvh.joints[h].name,
        "relative_to": "world" if ref is None else bvh.joints[ref].name,
        "chain": [bvh.joints[j].name for j in chain],
        "n_joints": len(bvh.joints), "joints": bvh.names,
    }
    return Motion(rotvec, bvh.fps, meta=meta)


def _path_from_root(bvh: BVHFile, child: int) -> list[int]:
    out = []
    j = child
    while j is not None:
        out.append(j)
        j = bvh.joints[j].parent
    return out[::-1]


# ------------------------------------------------------------------------------------------ write
_SKELETON = (  # name, offset (cm), Y-up, facing +Z
    ("Hips", (0.0, 95.0, 0.0)),
    ("Spine", (0.0, 10.0, 0.0)),
    ("Neck", (0.0, 45.0, 0.0)),
    ("Head", (0.0, 10.0, 0.0)),
)
_HEAD_TOP = (0.0, 18.0, 0.0)
#: Share of the rotation the Neck joint carries by default: measured on the ZEGGS take
#: (:func:`headmotion.motion.neck_share.measure_neck_share`, 0.93; quarters 0.92–0.96).
DEFAULT_NECK_SHARE = 0.93


def save_bvh(motion: Motion, path, *, channel_order: str = "ZXY", neck_share: float = DEFAULT_NECK_SHARE,
             euler_order: str | None = None) -> None:
    """Write ``motion`` as a BVH file (Hips → Spine → Neck → Head; see the module docstring).

    Parameters
    ----------
    motion : Motion
    path : str or Path
    channel_order : {"ZXY", "YXZ"}
        Order of the rotation channels of every joint (``euler_order`` is an alias).
    neck_share : float in [0, 1]
        Fraction of the rotation (of the rotation vector) carried by the neck joint (default
        :data:`DEFAULT_NECK_SHARE`, measured on real mocap; 0 = all on the head joint).
    """
    if euler_order is not None:
        channel_order = euler_order
    order = str(channel_order).upper()
    if order not in ("ZXY", "YXZ"):
        raise ParameterError(f"BVH channel order must be 'ZXY' or 'YXZ'; got {channel_order!r}")
    s = float(neck_share)
    if not 0.0 <= s <= 1.0:
        raise ParameterError(f"neck_share must be in [0, 1]; got {neck_share!r}")
    if not isinstance(motion, Motion):
        raise ParameterError(f"save_bvh needs a Motion; got {type(motion).__name__}")
    if len(motion) == 0:
        raise ParameterError("cannot write a BVH file with zero frames")
    # neck = R(s·r), head = neck⁻¹ ⊗ R(r), as Euler angles (scipy Rotation's steps, in numpy)
    r = quaternions.rotvec_to_quat(np.array(motion.rotvec))
    neck = quaternions.rotvec_to_quat(np.array(motion.rotvec) * s)
    head = quaternions.compose(neck * [-1.0, -1.0, -1.0, 1.0], r)
    neck_e = np.rad2deg(quaternions.quat_to_euler(neck, order))
    head_e = np.rad2deg(quaternions.quat_to_euler(head, order))
    chans = " ".join(f"{a}rotation" for a in order)
    T = len(motion)
    lines = ["HIERARCHY"]
    depth = 0
    for k, (name, off) in enumerate(_SKELETON):
        ind = "\t" * depth
        lines.append(f"{ind}{'ROOT' if k == 0 else 'JOINT'} {name}")
        lines.append(f"{ind}{{")
        lines.append(f"{ind}\tOFFSET {off[0]:.6f} {off[1]:.6f} {off[2]:.6f}")
        if k == 0:
            lines.append(f"{ind}\tCHANNELS 6 Xposition Yposition Zposition {chans}")
        else:
            lines.append(f"{ind}\tCHANNELS 3 {chans}")
        depth += 1
    ind = "\t" * depth
    lines += [f"{ind}End Site", f"{ind}{{", f"{ind}\tOFFSET {_HEAD_TOP[0]:.6f} {_HEAD_TOP[1]:.6f} {_HEAD_TOP[2]:.6f}",
              f"{ind}}}"]
    for d in range(depth - 1, -1, -1):
        lines.append("\t" * d + "}")
    lines += ["MOTION", f"Frames: {T}", f"Frame Time: {1.0 / motion.fps:.12g}"]
    data = np.zeros((T, 6 + 9))
    data[:, 1] = _SKELETON[0][1][1]
    data[:, 9:12] = neck_e
    data[:, 12:15] = head_e
    body = "\n".join(" ".join(f"{v:.6f}" for v in row) for row in data)
    text = "\n".join(lines) + "\n" + body + "\n"
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(text)


def bvh_info(path) -> dict:
    bvh = read_bvh_file(path)
    info = {"format": "bvh", "n_frames": len(bvh.frames), "fps": bvh.fps,
            "duration": len(bvh.frames) / bvh.fps, "joints": bvh.names}
    try:
        info["head_joint"] = bvh.joints[find_head(bvh)].name
    except NoHeadError:
        info["head_joint"] = None
    return info


__all__ = ["load_bvh", "save_bvh", "read_bvh_file", "find_head", "find_torso", "bvh_info", "BVHFile", "Joint"]
