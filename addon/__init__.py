"""Visuo-tactile skin: lay CySkin-style taxels on meshes, press objects against them
through soft layers, see responses, edges and tactile colours as mesh attributes.

A thin skin over ``vtcore`` (imported as a top-level package: the bundled wheel
when installed as an extension, the repository's install in development).
Registration concatenates the ``CLASSES`` tuples of the small modules.
"""

from __future__ import annotations

import bpy

from . import handlers, ops, panel, props

CLASSES = props.CLASSES + ops.CLASSES + panel.CLASSES


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    props.register_props()
    handlers.register()


def unregister():
    handlers.unregister()
    props.unregister_props()
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
