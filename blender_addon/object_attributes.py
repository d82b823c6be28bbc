"""The Attribute node's Object, Instancer and View Layer types: their values, found at export.

Cycles reads these attributes once per object (or instance) and once per render, not per
shading point (`blender/object.cpp`, `sync_object_attributes`, over Blender's
`BKE_object_dupli_find_rgba_attribute` and `BKE_view_layer_find_rgba_attribute`): a name is
looked up as a custom property of a data-block, then as an RNA path on it (`color`,
`location`, `["name"]`), and a number, a boolean or an array of up to four numbers becomes an
RGBA value (a scalar v as (v, v, v, 1), a shorter array padded with (0, 0, 0, 1)); a name found
nowhere reads (0, 0, 0, 0). Type Object looks on the object, then its data (the mesh); type
Instancer first on the instancer: the particle system's settings, the Geometry Nodes instance's
own attributes (the instance domain of the instancer's evaluated geometry), the instancer
object; type View Layer on the view layer, the scene and its world.

The add-on does the same: `attribute_slots` numbers the scene's (type, name) pairs of Object
and Instancer attributes (the nodes read `object_slot`), `instance_values` gives each mesh
node's values in that order (PHOTON_object "info" "attributes", export.py), and
`view_layer_value` the constant a View Layer attribute reads (the node's `value`). The fields
are specified in docs/gltf_extensions.md.
"""

from __future__ import annotations

# Object and Instancer attributes a scene may read (`shader::OBJECT_ATTRIBUTES`).
OBJECT_ATTRIBUTES = 8

# Attribute types read per object or instance.
PER_OBJECT = ("OBJECT", "INSTANCER")

NOT_FOUND = [0.0, 0.0, 0.0, 0.0]


def attribute_slots() -> dict[tuple[str, str], int]:
    """`{(type, name): slot}` of every Object and Instancer attribute read by a material or node
    group of the file, numbered in sorted order (the same on every call of one export)."""
    import bpy
    trees = [m.node_tree for m in bpy.data.materials if m.node_tree is not None]
    trees += [g for g in bpy.data.node_groups if g.bl_idname == "ShaderNodeTree"]
    pairs = {(n.attribute_type, n.attribute_name) for t in trees for n in t.nodes
             if n.bl_idname == "ShaderNodeAttribute" and n.attribute_type in PER_OBJECT}
    return {pair: k for k, pair in enumerate(sorted(pairs))}


def _rgba(value) -> list[float] | None:
    """A property's value as RGBA, as Blender's `find_property_rgba` converts it; None for a
    value it does not convert (a string, a pointer, an array longer than 4 or of booleans)."""
    if isinstance(value, bool):
        v = 1.0 if value else 0.0
        return [v, v, v, 1.0]
    if isinstance(value, (int, float)):
        v = float(value)
        return [v, v, v, 1.0]
    if isinstance(value, str):
        return None
    try:
        items = list(value)
    except TypeError:
        return None
    if not items or len(items) > 4:
        return None
    if not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in items):
        return None  # nested (a matrix), booleans or pointers
    rgba = [0.0, 0.0, 0.0, 1.0]
    rgba[:len(items)] = [float(x) for x in items]
    return rgba


def property_rgba(owner, name: str) -> list[float] | None:
    """`name` on `owner` (a data-block or a view layer): its custom property of that name, else
    the RNA path `name`; None where neither gives a value `_rgba` converts."""
    if owner is None:
        return None
    try:
        if name in owner.keys():
            return _rgba(owner[name])
    except (TypeError, AttributeError):
        pass
    try:
        value = owner.path_resolve(name)
    except (ValueError, AttributeError, TypeError):
        return None
    return _rgba(value)


def _instance_domain(parent, name: str) -> list | None:
    """Attribute `name` of the instance domain of `parent`'s evaluated geometry (its
    instances), as RGBA per instance (Blender's conversion to a colour); None without it."""
    try:
        geometry = parent.evaluated_geometry()
        cloud = geometry.instances_pointcloud()
    except (AttributeError, RuntimeError):
        return None
    if cloud is None or name not in cloud.attributes:
        return None
    attribute = cloud.attributes[name]
    kind = attribute.data_type
    if kind in ("FLOAT_COLOR", "BYTE_COLOR"):
        # Scene linear, as Blender converts a byte colour.
        return [[float(x) for x in item.color] for item in attribute.data]
    if kind in ("FLOAT_VECTOR", "FLOAT2"):
        return [_rgba(item.vector) for item in attribute.data]
    if kind in ("FLOAT", "INT", "INT8", "BOOLEAN"):
        return [_rgba(item.value) for item in attribute.data]
    return None


def _object_rgba(obj, parent, name: str) -> list[float] | None:
    """`property_rgba` on object `obj`, shown by instancer `parent` (None: not an instance):
    an instance's Object Color is its instancer's, as Blender's depsgraph gives each instance
    (`deg_iterator_duplis_step`), which is what Cycles reads."""
    if parent is not None and name == "color" and name not in obj.keys():
        return _rgba(parent.color)
    return property_rgba(obj, name)


class InstanceLookup:
    """Object and Instancer attribute values of depsgraph instances and plain objects, slot by
    slot (`attribute_slots`)."""

    def __init__(self, slots: dict[tuple[str, str], int]):
        self.pairs = sorted(slots, key=slots.get)
        # Per (instancer, name): the instance domain's values (`_instance_domain`).
        self.domains: dict[tuple[str, str], list | None] = {}

    def values(self, obj, *, parent=None, particles=None, index=-1) -> list[list[float]]:
        """The values for object `obj` shown by instancer `parent` (None: not an instance),
        through particle system `particles`, as Geometry Nodes instance `index`."""
        out = []
        for kind, name in self.pairs:
            found = None
            if kind == "INSTANCER" and parent is not None:
                if particles is not None:
                    found = property_rgba(particles.settings, name)
                if found is None and index >= 0:
                    key = (parent.name, name)
                    if key not in self.domains:
                        self.domains[key] = _instance_domain(parent, name)
                    domain = self.domains[key]
                    if domain is not None and index < len(domain):
                        found = domain[index]
                if found is None:
                    found = property_rgba(parent, name)
            if found is None:
                found = _object_rgba(obj, parent, name)
            if found is None:
                found = property_rgba(getattr(obj, "data", None), name)
            out.append(found if found is not None else list(NOT_FOUND))
        return out


def view_layer_value(name: str) -> list[float]:
    """A View Layer attribute: on the render's view layer, the scene, then its world."""
    import bpy
    scene = bpy.context.scene
    for owner in (bpy.context.view_layer, scene, scene.world):
        found = property_rgba(owner, name)
        if found is not None:
            return found
    return list(NOT_FOUND)
