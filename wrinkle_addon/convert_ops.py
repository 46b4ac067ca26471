# SPDX-License-Identifier: GPL-3.0-or-later
"""(being written this session)"""

import bpy

classes = ()
_register, _unregister = bpy.utils.register_classes_factory(classes)


def register():
    _register()


def unregister():
    _unregister()
