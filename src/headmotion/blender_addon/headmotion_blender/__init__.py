"""HeadMotion for Blender: head motion from speech, keyed on a character's neck and head.

A panel in the 3D view's sidebar (tab "HeadMotion") and the operator
``bpy.ops.headmotion.generate(filepath=, model=, seed=, amount=)``, which runs the installed
``headmotion`` command (on PATH, or the path set in this add-on's preferences) and keys the
active armature's neck and head bones at the scene's frame rate from the current frame
(:mod:`.operators`, :mod:`.rig`, :mod:`.bones`, :mod:`.runner`).  Installs as a legacy add-on
(Blender 3.4 to 4.1: Preferences > Add-ons > Install) and as an extension (4.2 and later:
``blender_manifest.toml``).  Written by ``headmotion blender-addon -o headmotion_blender.zip``.
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from . import operators

bl_info = {
    "name": "HeadMotion",
    "author": "the headmotion authors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > HeadMotion",
    "description": "Head motion from speech, keyed on a character's neck and head",
    "category": "Animation",
}


class HeadMotionPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    executable: StringProperty(name="headmotion command", subtype="FILE_PATH",
                               description="The headmotion program to run (empty: the one on PATH)")

    def draw(self, context):  # noqa: ARG002 - Blender's signature
        self.layout.prop(self, "executable")


class HeadMotionSettings(bpy.types.PropertyGroup):
    filepath: StringProperty(name="Speech", subtype="FILE_PATH", description="Speech audio (wav, flac, mp3, ...)")
    model: StringProperty(name="Model", default="default",
                          description="A shipped model's name (default, stream) or a model file")
    seed: IntProperty(name="Seed", default=0, min=0)
    amount: FloatProperty(name="Amount", default=1.0, min=0.0, max=3.0,
                          description="How much the head moves: 1 natural, 2 animated, 0.5 calm, 0 still")
    neck_share: FloatProperty(name="Neck share", default=operators.DEFAULT_NECK_SHARE, min=0.0, max=1.0)
    preset: EnumProperty(name="Bones", items=operators.PRESET_ITEMS, default="AUTO")
    neck_bone: StringProperty(name="Neck bone", description="Empty: by preset")
    head_bone: StringProperty(name="Head bone", description="Empty: by preset")
    from_strip: BoolProperty(name="From the active sound strip")
    add_sound: BoolProperty(name="Add a sound strip", default=True)


class VIEW3D_PT_headmotion(bpy.types.Panel):
    bl_label = "HeadMotion"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "HeadMotion"

    def draw(self, context):
        s = context.scene.headmotion
        col = self.layout.column()
        col.prop(s, "from_strip")
        row = col.row()
        row.enabled = not s.from_strip
        row.prop(s, "filepath")
        for name in ("model", "seed", "amount", "preset", "neck_bone", "head_bone", "neck_share"):
            col.prop(s, name)
        sub = col.row()
        sub.enabled = not s.from_strip
        sub.prop(s, "add_sound")
        op = col.operator(operators.HEADMOTION_OT_generate.bl_idname, icon="ARMATURE_DATA")
        for name in ("filepath", "model", "seed", "amount", "neck_share", "preset", "neck_bone", "head_bone",
                     "from_strip", "add_sound"):
            setattr(op, name, getattr(s, name))


CLASSES = (HeadMotionPreferences, HeadMotionSettings, operators.HEADMOTION_OT_generate, VIEW3D_PT_headmotion)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Scene.headmotion = PointerProperty(type=HeadMotionSettings)


def unregister():
    del bpy.types.Scene.headmotion
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
