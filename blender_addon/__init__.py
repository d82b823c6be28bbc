"""Photon for Blender: registers the render engine "Photon", its settings and panels.

The glTF exporter looks for `glTF2ExportUserExtension` in the top-level module of each enabled
add-on, so the hook class defined in export.py is made visible here.
"""

from . import engine, merge, properties, ui
from .export import glTF2ExportUserExtension  # noqa: F401 - found by the glTF exporter

modules = (properties, engine, merge, ui)


def register():
    for module in modules:
        module.register()


def unregister():
    for module in reversed(modules):
        module.unregister()
