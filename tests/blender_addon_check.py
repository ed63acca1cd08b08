"""Run inside Blender (``blender -b --factory-startup --python THIS -- ZIP HEADMOTION AUDIO OUT.json``) by
tests/test_blender_addon.py: installs the add-on from its zip, builds rigs whose neck and head bones
have unusual rest orientations and rolls, keys them with ``bpy.ops.headmotion.generate`` and writes
what it measured: per frame, the head's and the neck's rotation against their rest pose in the
space of the neck's parent, and the one-line reports of the refusals."""

import json
import math
import os
import sys

import bpy
from mathutils import Vector

argv = sys.argv[sys.argv.index("--") + 1:]
ZIP, EXE, AUDIO, OUT = argv[:4]


def armature(name, chain, mode="QUATERNION"):
    """An armature of connected bones: chain = [(name, parent, head, tail, roll), ...]."""
    bpy.ops.object.select_all(action="DESELECT") if bpy.context.object else None
    data = bpy.data.armatures.new(name)
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    for bname, parent, head, tail, roll in chain:
        eb = data.edit_bones.new(bname)
        eb.head, eb.tail, eb.roll = Vector(head), Vector(tail), roll
        if parent:
            eb.parent = data.edit_bones[parent]
    bpy.ops.object.mode_set(mode="OBJECT")
    for pb in obj.pose.bones:
        pb.rotation_mode = mode
    return obj


def measure(obj, neck, head, first, count):
    """Per frame: the head's and the neck's rotation against rest, in the neck's parent's space."""
    scene = bpy.context.scene
    nb, hb = obj.pose.bones[neck] if neck else None, obj.pose.bones[head]
    ref = (nb or hb).parent

    def delta(pb):
        return pb.matrix.to_3x3() @ pb.bone.matrix_local.to_3x3().inverted()

    heads, necks = [], []
    for k in range(count):
        scene.frame_set(first + k)
        parent = delta(ref) if ref is not None else None
        h = delta(hb) if parent is None else parent.inverted() @ delta(hb)
        heads.append([list(r) for r in h])
        if nb is not None:
            n = delta(nb) if parent is None else parent.inverted() @ delta(nb)
            necks.append([list(r) for r in n])
    return {"head": heads, "neck": necks}


def keyed(obj):
    ad = obj.animation_data
    return 0 if ad is None or ad.action is None else sum(len(fc.keyframe_points) for fc in ad.action.fcurves)


def refusal(**kw):
    try:
        bpy.ops.headmotion.generate(**kw)
    except RuntimeError as exc:
        return str(exc).strip()
    return None


bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.preferences.addon_install(filepath=ZIP, overwrite=True)
bpy.ops.preferences.addon_enable(module="headmotion_blender")
prefs = bpy.context.preferences.addons["headmotion_blender"].preferences
scene = bpy.context.scene
result = {"blender": bpy.app.version_string, "rigs": {}, "errors": {}}

# 1. VRoid names, bones leaning and rolled, quaternions, 30 fps from frame 7, the command from PATH
scene.render.fps, scene.render.fps_base = 30, 1.0
scene.frame_current = 7
vroid = armature("vroid", [
    ("J_Bip_C_Hips", None, (0, 0, 1.0), (0, 0, 1.1), 0.0),
    ("J_Bip_C_Chest", "J_Bip_C_Hips", (0, 0, 1.1), (0, 0.01, 1.4), 0.2),
    ("J_Bip_C_Neck", "J_Bip_C_Chest", (0, 0.01, 1.4), (0.03, -0.02, 1.5), 0.65),
    ("J_Bip_C_Head", "J_Bip_C_Neck", (0.03, -0.02, 1.5), (0.0, -0.09, 1.63), -1.9),
])
bpy.ops.headmotion.generate(filepath=AUDIO, model="default", seed=3, amount=1.5)
n = len(vroid.animation_data.action.fcurves[0].keyframe_points)
result["rigs"]["vroid"] = {"fps": 30.0, "first": 7, "frames": n, "neck_share": 0.93,
                           **measure(vroid, "J_Bip_C_Neck", "J_Bip_C_Head", 7, n)}

# 2. UE names, an unkeyed neck_02 between neck and head, bones lying sideways, Euler and axis-angle
#    modes, 24 fps from frame 1, the command from the preferences, another neck share
prefs.executable = EXE
scene.render.fps = 24
scene.frame_current = 1
ue = armature("ue", [
    ("pelvis", None, (0, 0, 1.0), (0, 0.1, 1.0), 0.4),
    ("spine_01", "pelvis", (0, 0.1, 1.0), (0, 0.1, 1.4), -0.3),
    ("neck_01", "spine_01", (0, 0.1, 1.4), (0.1, 0.1, 1.43), 1.2),
    ("neck_02", "neck_01", (0.1, 0.1, 1.43), (0.1, 0.0, 1.48), 0.3),
    ("head", "neck_02", (0.1, 0.0, 1.48), (0.08, 0.05, 1.58), 2.5),
], mode="YXZ")
ue.pose.bones["head"].rotation_mode = "AXIS_ANGLE"
bpy.ops.headmotion.generate(filepath=AUDIO, seed=0, amount=1.0, neck_share=0.5)
n = len(ue.animation_data.action.fcurves[0].keyframe_points)
result["rigs"]["ue"] = {"fps": 24.0, "first": 1, "frames": n, "neck_share": 0.5,
                        "modes": [ue.pose.bones["neck_01"].rotation_mode, ue.pose.bones["head"].rotation_mode],
                        "neck_02_keyed": any("neck_02" in fc.data_path for fc in ue.animation_data.action.fcurves),
                        **measure(ue, "neck_01", "head", 1, n)}

# 3. Mixamo names (numbered prefix), the active sound strip at frame 40 as the input, 29.97 fps
scene.render.fps, scene.render.fps_base = 30, 1.001
scene.sequence_editor_create()
strips = getattr(scene.sequence_editor, "strips", None) or scene.sequence_editor.sequences
strip = strips.new_sound("line", AUDIO, 1, 40)
scene.sequence_editor.active_strip = strip
mixamo = armature("mixamo", [
    ("mixamorig2:Spine2", None, (0, 0, 1.2), (0, 0, 1.4), 0.0),
    ("mixamorig2:Neck", "mixamorig2:Spine2", (0, 0, 1.4), (0, -0.02, 1.5), math.pi),
    ("mixamorig2:Head", "mixamorig2:Neck", (0, -0.02, 1.5), (0, -0.02, 1.65), -0.7),
])
scene.frame_current = 3
bpy.ops.headmotion.generate(from_strip=True, seed=1)
n = len(mixamo.animation_data.action.fcurves[0].keyframe_points)
result["rigs"]["mixamo"] = {"fps": 30 / 1.001, "first": 40, "frames": n, "neck_share": 0.93,
                            "first_key": mixamo.animation_data.action.fcurves[0].keyframe_points[0].co[0],
                            **measure(mixamo, "mixamorig2:Neck", "mixamorig2:Head", 40, n)}

# 4. the speech added as a sound strip at the first keyed frame
scene.render.fps, scene.render.fps_base = 25, 1.0
scene.frame_current = 100
plain = armature("plain", [("Spine", None, (0, 0, 1), (0, 0, 1.3), 0), ("Neck", "Spine", (0, 0, 1.3), (0, 0, 1.4), 0),
                           ("Head", "Neck", (0, 0, 1.4), (0, 0, 1.55), 0)])
bpy.ops.headmotion.generate(filepath=AUDIO, add_sound=True)
added = [s for s in strips if s.type == "SOUND" and s.name != "line"]
result["sound_strip"] = [(s.frame_start, bpy.path.abspath(s.sound.filepath)) for s in added]

# refusals: one line each, nothing keyed
bare = armature("bare", [("Bone", None, (0, 0, 0), (0, 0, 1), 0), ("Bone.001", "Bone", (0, 0, 1), (0, 0, 2), 0)])
result["errors"]["no_head"] = refusal(filepath=AUDIO)
fresh = armature("fresh", [("Neck", None, (0, 0, 1.3), (0, 0, 1.4), 0), ("Head", "Neck", (0, 0, 1.4), (0, 0, 1.5), 0)])
bad = os.path.join(os.path.dirname(OUT), "bad.wav")
with open(bad, "w") as fh:
    fh.write("not audio at all")
result["errors"]["bad_audio"] = refusal(filepath=bad)
result["errors"]["missing_audio"] = refusal(filepath=bad + ".missing")
prefs.executable = "/nonexistent/headmotion"
result["errors"]["no_headmotion"] = refusal(filepath=AUDIO)
prefs.executable = ""
os.environ["PATH"] = "/nonexistent"
result["errors"]["not_on_path"] = refusal(filepath=AUDIO)
empty = bpy.data.objects.new("empty", None)
scene.collection.objects.link(empty)
bpy.context.view_layer.objects.active = empty
result["errors"]["no_armature"] = refusal(filepath=AUDIO)
result["keys_after_refusals"] = keyed(bare) + keyed(fresh)
with open(OUT, "w") as fh:
    json.dump(result, fh)
