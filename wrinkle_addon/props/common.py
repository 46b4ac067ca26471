# SPDX-License-Identifier: GPL-3.0-or-later
"""Update callbacks and polls that the property files share."""

# The update callbacks import the glue lazily: the glue reads these properties.


def refresh(self, context):
    """Re-evaluate the wrinkles after a parameter change (the frame stage notices the
    change itself by its cache keys, so undo, drivers and animation are safe too)."""
    from ..glue import pipeline

    pipeline.refresh_all(context)


def is_muscle(self, ob):
    return ob.type == "MESH" and ob.ewrinkles_muscle.is_muscle
