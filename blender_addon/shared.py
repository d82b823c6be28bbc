"""What the export's modules share: the logger their warnings go to and the object types the
glTF exporter writes as meshes. It imports nothing but the standard library."""

import logging

# The export's own messages; collected with the glTF exporter's during an export
# (export.collected_warnings) and shown to the user.
LOG = logging.getLogger("photon.export")

# Object types the glTF exporter writes as meshes.
GEOMETRY_TYPES = ("MESH", "CURVE", "SURFACE", "META", "FONT")
