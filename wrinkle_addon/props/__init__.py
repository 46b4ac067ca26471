# SPDX-License-Identifier: GPL-3.0-or-later
"""The data model: property groups registered on Blender's own types.

Every property registered on a Blender type carries the add-on prefix ``ewrinkles_``
(``Object.ewrinkles_face`` on faces, ``Object.ewrinkles_muscle`` on muscles,
``Object.ewrinkles_curve`` on wrinkle curves), so it cannot
clash with another add-on.  Files saved by version 0.2 used unprefixed names; ``migrate``
moves their data over on load.  Every property has a description (its tooltip), units
where they apply and soft limits that keep an artist in the useful range.
"""

import bpy
from bpy.props import PointerProperty

from . import bando, face, maps, migrate, muscles, patterns

PREFIX = "ewrinkles_"
classes = (muscles.WrinkleMuscleSettings, muscles.WrinkleMuscleRef, maps.WrinkleMapExpression,
           maps.WrinkleMapSettings, bando.WrinkleCurveSettings, bando.WrinkleCurveRef,
           patterns.PatternLayer, face.WrinkleFaceSettings)
_register, _unregister = bpy.utils.register_classes_factory(classes)


def register():
    _register()
    bpy.types.Object.ewrinkles_muscle = PointerProperty(type=muscles.WrinkleMuscleSettings)
    bpy.types.Object.ewrinkles_face = PointerProperty(type=face.WrinkleFaceSettings)
    bpy.types.Object.ewrinkles_curve = PointerProperty(type=bando.WrinkleCurveSettings)
    migrate.register()


def unregister():
    migrate.unregister()
    del bpy.types.Object.ewrinkles_curve
    del bpy.types.Object.ewrinkles_face
    del bpy.types.Object.ewrinkles_muscle
    _unregister()
