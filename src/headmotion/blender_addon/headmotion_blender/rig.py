"""Head motion onto a rig's neck and head bones: the rotation of each bone's pose, and its keys.

headmotion's axes (+x the speaker's left, +y up, +z forward) are those of a character facing -Y
with +Z up in the armature's space: x -> +X, y -> +Z, z -> -Y, so a rotation vector (rx, ry, rz)
becomes (rx, -rz, ry) there.  The rotation D is spread over the neck and the head as headmotion's
BVH writer does: the neck turns by D_n = exp(s r) (s: the neck's share), the head by the rest, so
that the head's rotation against its rest pose, in the space of the neck's parent, is D.  In a
bone's own frame (its rest orientation and roll, whatever they are) the neck's pose rotation is
N⁻¹ D_n N and the head's H⁻¹ D_n⁻¹ D H, with N and H the bones' rest orientations in armature space
(bones between the neck and the head stay at rest).
"""

from mathutils import Euler, Quaternion, Vector


def _quat(v):
    angle = v.length
    return Quaternion(v / angle, angle) if angle > 0.0 else Quaternion()


def pose_rotations(frames, neck_rest, head_rest, share):
    """Per frame, the neck's (None without a neck) and the head's pose rotation as quaternions.

    ``frames``: rotation vectors in headmotion's axes; ``neck_rest``/``head_rest``: the bones'
    ``matrix_local`` (``neck_rest`` None: everything on the head)."""
    hr = head_rest.to_quaternion()
    hr_inv = hr.inverted()
    nr = None if neck_rest is None else neck_rest.to_quaternion()
    s = share if nr is not None else 0.0
    necks, heads = [], []
    for rx, ry, rz in frames:
        b = Vector((rx, -rz, ry))
        d = _quat(b)
        dn = _quat(b * s)
        heads.append(hr_inv @ dn.inverted() @ d @ hr)
        if nr is not None:
            necks.append(nr.inverted() @ dn @ nr)
    return (necks if nr is not None else None), heads


def channel_values(quats, mode):
    """The values to key for a bone in rotation mode ``mode``: (property, rows), continuous from
    frame to frame (quaternions on one hemisphere, Euler angles compatible with the previous)."""
    rows = []
    if mode == "QUATERNION":
        prev = None
        for q in quats:
            q = q.copy()
            if prev is not None and prev.dot(q) < 0.0:
                q.negate()
            rows.append(tuple(q))
            prev = q
        return "rotation_quaternion", rows
    if mode == "AXIS_ANGLE":
        for q in quats:
            axis, angle = q.to_axis_angle()
            rows.append((angle, axis.x, axis.y, axis.z))
        return "rotation_axis_angle", rows
    prev = Euler((0.0, 0.0, 0.0), mode)
    for q in quats:
        e = q.to_euler(mode, prev)
        rows.append(tuple(e))
        prev = e
    return "rotation_euler", rows


def _fcurves(obj):
    """The F-curves of ``obj``'s action (made when missing), in every Blender since 3.4."""
    import bpy

    adt = obj.animation_data or obj.animation_data_create()
    if adt.action is None:
        adt.action = bpy.data.actions.new(name=f"{obj.name}Action")
    action = adt.action
    slots = getattr(action, "slots", None)
    if slots is not None and hasattr(adt, "action_slot"):  # layered actions (4.4 and later)
        if adt.action_slot is None:
            adt.action_slot = slots[0] if len(slots) else slots.new(id_type="OBJECT", name=obj.name)
        try:
            from bpy_extras import anim_utils

            return anim_utils.action_ensure_channelbag_for_slot(action, adt.action_slot).fcurves
        except (ImportError, AttributeError):
            pass
    return action.fcurves


def _curve(fcurves, path, index, group):
    fc = fcurves.find(path, index=index)
    if fc is not None:
        return fc
    try:
        return fcurves.new(path, index=index, action_group=group)
    except TypeError:  # a channel bag's F-curves take no group
        return fcurves.new(path, index=index)


def key_bone(obj, bone_name, prop, rows, first_frame):
    """Key ``rows`` on the pose bone's ``prop`` at ``first_frame``, ``first_frame + 1``, …,
    replacing the keys already there in that range (LINEAR interpolation: one key per frame)."""
    import bpy

    fcurves = _fcurves(obj)
    path = f'pose.bones["{bpy.utils.escape_identifier(bone_name)}"].{prop}'
    last = first_frame + len(rows) - 1
    for i in range(len(rows[0])):
        fc = _curve(fcurves, path, i, bone_name)
        pts = fc.keyframe_points
        for p in reversed([p for p in pts if first_frame - 0.5 <= p.co[0] <= last + 0.5]):
            pts.remove(p, fast=True)
        n0 = len(pts)
        pts.add(len(rows))
        co = [0.0] * (2 * len(pts))
        pts.foreach_get("co", co)
        for k, row in enumerate(rows):
            co[2 * (n0 + k)] = float(first_frame + k)
            co[2 * (n0 + k) + 1] = float(row[i])
        pts.foreach_set("co", co)
        for p in pts[n0:]:
            p.interpolation = "LINEAR"
        fc.update()
