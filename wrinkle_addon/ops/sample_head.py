# SPDX-License-Identifier: GPL-3.0-or-later
"""Add Sample Head: the scanned ICT head the add-on ships, to try every method on."""

import bpy
from bpy.props import BoolProperty

from ..glue import sample_head
from ..glue.progress import Progress
from .common import guarded, nothing_left_on_failure, select_only


class WRINKLE_OT_add_sample_head(bpy.types.Operator):
    """Add the scanned ICT head (MIT licence) with its 53 ARKit expression shape keys, a skin
    material, and eyes, lashes and teeth that follow its blinks and jaw: a face to try every
    wrinkle method on"""

    bl_idname = "wrinkle.add_sample_head"
    bl_label = "Add Sample Head"
    bl_options = {"REGISTER", "UNDO"}

    parts: BoolProperty(
        name="Eyes, Lashes and Teeth",
        description="Also add the eyes, lacrimal fluid, lashes, teeth, gums and tongue, parented "
        "to the head; their shape keys follow the head's through drivers",
        default=True,
    )

    @classmethod
    def poll(cls, context):
        if context.mode != "OBJECT":
            cls.poll_message_set("Switch to Object Mode to add the sample head")
            return False
        return True

    @guarded
    def execute(self, context):
        with nothing_left_on_failure(), Progress(context, self.bl_label) as progress:
            skin, _parts = sample_head.add(context.collection, parts=self.parts, progress=progress)
        skin.location = context.scene.cursor.location
        select_only(context, skin)
        self.report({"INFO"}, f'Added "{skin.name}" with {len(skin.data.shape_keys.key_blocks) - 1} '
                              "expression shape keys; press Enable Wrinkles in the Wrinkles tab")
        return {"FINISHED"}


def menu_func(self, context):
    self.layout.operator(WRINKLE_OT_add_sample_head.bl_idname, icon="USER")


classes = (WRINKLE_OT_add_sample_head,)
_register, _unregister = bpy.utils.register_classes_factory(classes)


def register():
    _register()
    bpy.types.VIEW3D_MT_mesh_add.append(menu_func)


def unregister():
    bpy.types.VIEW3D_MT_mesh_add.remove(menu_func)
    _unregister()
