"""``bpy.ops.headmotion.generate``: head motion from speech, keyed on the active armature.

Run from a script (``execute``) it waits for ``headmotion``; from the panel (``invoke``) it runs
modally with a timer: the status bar shows what it is doing and for how long, Esc cancels (the
subprocess is stopped, nothing is keyed).  Every check is made before anything changes, and the
keys are written only once the whole motion has come back: an error is one line in Blender's
report and nothing keyed.
"""

import os
import time

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from . import bones, rig, runner

DEFAULT_NECK_SHARE = 0.93  # headmotion.io.bvh.DEFAULT_NECK_SHARE, measured on mocap

PRESET_ITEMS = [("AUTO", "Automatic", "Try every preset")] + \
    [(pid, label, label) for pid, label, _n, _h in bones.PRESETS] + [("CUSTOM", "Names given", "Only the names set")]


class Refused(Exception):
    """A one-line reason not to start."""


def _vrm_map(armature):
    """(neck, head) of the VRM add-on's humanoid map on this armature, when there is one."""
    ext = getattr(armature, "vrm_addon_extension", None)
    try:
        if ext is not None and ext.is_vrm1():
            hb = ext.vrm1.humanoid.human_bones
            return (hb.neck.node.bone_name or None, hb.head.node.bone_name or None)
        if ext is not None:
            found = {b.bone: b.node.bone_name for b in ext.vrm0.humanoid.human_bones}
            return (found.get("neck") or None, found.get("head") or None)
    except AttributeError:
        pass
    return (None, None)


def _strips(scene):
    se = scene.sequence_editor
    if se is None:
        return None
    return getattr(se, "strips", None) or se.sequences


def _preferences(context):
    addon = context.preferences.addons.get(__package__)
    return getattr(addon, "preferences", None)


class HEADMOTION_OT_generate(bpy.types.Operator):
    """Make head motion from speech with headmotion and key it on the active armature's neck and head"""

    bl_idname = "headmotion.generate"
    bl_label = "Generate head motion"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="Speech", subtype="FILE_PATH", description="Speech audio (wav, flac, mp3, ...)")
    model: StringProperty(name="Model", default="default",
                          description="A shipped model's name (default, stream) or a model file")
    seed: IntProperty(name="Seed", default=0, min=0, description="The same seed, the same motion")
    amount: FloatProperty(name="Amount", default=1.0, min=0.0, max=3.0,
                          description="How much the head moves: 1 natural, 2 animated, 0.5 calm, 0 still")
    neck_share: FloatProperty(name="Neck share", default=DEFAULT_NECK_SHARE, min=0.0, max=1.0,
                              description="Share of the rotation on the neck bone, the rest on the head")
    preset: EnumProperty(name="Bones", items=PRESET_ITEMS, default="AUTO")
    neck_bone: StringProperty(name="Neck bone", description="The neck bone's name (empty: by preset)")
    head_bone: StringProperty(name="Head bone", description="The head bone's name (empty: by preset)")
    from_strip: BoolProperty(name="From sound strip", description="Use the active sound strip's audio, keyed "
                             "from the strip's first frame")
    add_sound: BoolProperty(name="Add sound strip", description="Add the speech as a sound strip at the first "
                            "keyed frame")

    # -- checks, before anything runs --------------------------------------------------------------
    def _plan(self, context):
        obj = context.active_object
        if obj is None or obj.type != "ARMATURE":
            raise Refused("the active object is not an armature; select the character's armature")
        scene = context.scene
        start = scene.frame_current
        if self.from_strip:
            strip = scene.sequence_editor.active_strip if scene.sequence_editor else None
            if strip is None or strip.type != "SOUND" or strip.sound is None:
                raise Refused("no active sound strip to take the speech from")
            if strip.sound.packed_file is not None:
                raise Refused(f"the sound strip {strip.name!r} is packed in the .blend; unpack it to a file first")
            audio = bpy.path.abspath(strip.sound.filepath)
            start = int(round(strip.frame_start))
        else:
            audio = bpy.path.abspath(self.filepath) if self.filepath else ""
        if not audio:
            raise Refused("no speech file given")
        audio = os.path.abspath(audio)
        if not os.path.isfile(audio):
            raise Refused(f"speech file not found: {audio}")
        parents = {b.name: (b.parent.name if b.parent else None) for b in obj.data.bones}
        preset = "CUSTOM" if (self.preset == "CUSTOM" or self.head_bone) else self.preset
        if preset == "CUSTOM" and not self.head_bone:
            raise Refused("set the head bone's name (or choose a preset)")
        try:
            neck, head, _how = bones.find_neck_and_head(parents, preset, self.neck_bone, self.head_bone,
                                                         _vrm_map(obj.data))
        except LookupError as exc:
            raise Refused(str(exc)) from None
        prefs = _preferences(context)
        try:
            exe = runner.find_executable(getattr(prefs, "executable", ""))
        except runner.RunError as exc:
            raise Refused(str(exc)) from None
        model = self.model.strip() or "default"
        if model.startswith("//"):
            model = bpy.path.abspath(model)
        fps = scene.render.fps / scene.render.fps_base
        return {"object": obj.name, "neck": neck, "head": head, "audio": audio, "start": start, "fps": fps,
                "exe": exe, "model": model}

    def _start(self, plan):
        try:
            return runner.Synthesis(plan["exe"], plan["audio"], plan["fps"], plan["model"], self.seed, self.amount)
        except runner.RunError as exc:
            raise Refused(str(exc)) from None

    # -- keying ------------------------------------------------------------------------------------
    def _key(self, context, plan, frames):
        obj = bpy.data.objects.get(plan["object"])
        if obj is None or obj.type != "ARMATURE":
            raise Refused("the armature is gone")
        if not frames:
            raise Refused("headmotion returned no frames")
        head_b = obj.data.bones.get(plan["head"])
        neck_b = obj.data.bones.get(plan["neck"]) if plan["neck"] else None
        if head_b is None or (plan["neck"] and neck_b is None):
            raise Refused("the neck or head bone is gone")
        necks, heads = rig.pose_rotations(frames, None if neck_b is None else neck_b.matrix_local,
                                          head_b.matrix_local, self.neck_share)
        todo = [(plan["head"], heads)] + ([(plan["neck"], necks)] if necks is not None else [])
        values = [(name, *rig.channel_values(q, obj.pose.bones[name].rotation_mode)) for name, q in todo]
        for name, prop, rows in values:
            rig.key_bone(obj, name, prop, rows, plan["start"])
        scene = context.scene
        last = plan["start"] + len(frames) - 1
        if scene.frame_end < last:
            scene.frame_end = last
        if self.add_sound and not self.from_strip:
            self._add_sound(scene, plan)
        on = f"{plan['neck']} and {plan['head']}" if plan["neck"] else plan["head"]
        self.report({"INFO"}, f"HeadMotion: keyed {len(frames)} frames on {on}, frames {plan['start']}–{last}")

    def _add_sound(self, scene, plan):
        if scene.sequence_editor is None:
            scene.sequence_editor_create()
        strips = _strips(scene)
        channel = min(128, 1 + max([s.channel for s in strips], default=0))
        strips.new_sound(os.path.basename(plan["audio"]), plan["audio"], channel, plan["start"])

    # -- entry points ------------------------------------------------------------------------------
    def execute(self, context):
        try:
            plan = self._plan(context)
            job = self._start(plan)
            job.wait()
            try:
                _fps, frames = job.result()
            except runner.RunError as exc:
                raise Refused(str(exc)) from None
            self._key(context, plan, frames)
        except Refused as exc:
            self.report({"ERROR"}, f"HeadMotion: {exc}")
            return {"CANCELLED"}
        return {"FINISHED"}

    def invoke(self, context, event):  # noqa: ARG002 - Blender's signature
        try:
            self._plan_ = self._plan(context)
            self._job = self._start(self._plan_)
        except Refused as exc:
            self.report({"ERROR"}, f"HeadMotion: {exc}")
            return {"CANCELLED"}
        self._t0 = time.monotonic()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        self._status(context)
        return {"RUNNING_MODAL"}

    def _status(self, context, text=None):
        if text is None:
            name = os.path.basename(self._plan_["audio"])
            text = f"HeadMotion: synthesising {name} … {time.monotonic() - self._t0:.1f} s (Esc to cancel)"
        if context.workspace is not None:
            context.workspace.status_text_set(text)

    def _end(self, context):
        context.window_manager.event_timer_remove(self._timer)
        if context.workspace is not None:
            context.workspace.status_text_set(None)

    def modal(self, context, event):
        if event.type == "ESC":
            self._job.cancel()
            self._end(context)
            self.report({"WARNING"}, "HeadMotion: cancelled; nothing keyed")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if not self._job.poll():
            self._status(context)
            return {"RUNNING_MODAL"}
        self._end(context)
        try:
            _fps, frames = self._job.result()
            self._key(context, self._plan_, frames)
        except (Refused, runner.RunError) as exc:
            self.report({"ERROR"}, f"HeadMotion: {exc}")
            return {"CANCELLED"}
        return {"FINISHED"}

    def cancel(self, context):
        self._job.cancel()
        self._end(context)
