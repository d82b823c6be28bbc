"""Point clouds and hair curves as meshes the glTF exporter writes, for the time of an export.

Cycles renders a point cloud's points as spheres of their radius and a Curves object's curves
(hair) as round tubes of their radius; the glTF exporter writes neither. Within
`as_meshes(scene)` each rendered Point Cloud and Curves object carries one more Geometry Nodes
modifier (removed afterwards) that turns its points into instances of one sphere mesh, scaled
by each point's radius, and its curves into a tube mesh swept along them (a circle profile
scaled by the curve's radius), both with the first material of the object's evaluated
geometry. The exporter writes
instances as nodes sharing one mesh (its depsgraph-instance export), so the renderer stores the
sphere once and places it per point (its two-level BVH). Hair particle systems are first
turned into such Curves objects (`hair_particles_as_curves`, Cycles' strand radius).

The sphere and the tube are polygons inscribed in the true shapes; both are enlarged so that
their mean projected size is the true one: a convex body's mean projected area is a quarter of
its surface area (Cauchy), and a regular n-gon's mean width is its perimeter over π.

A tube's UV map (`TUBE_UV_MAP`) holds the curve's parameter from root (0) to tip (1) in u:
the renderer takes the fibre's direction, which hair BSDFs scatter around, from its gradient
(src/material.rs, `fibre_tangent`), and the offset across the fibre from the view and the
tube's smooth normal (src/bsdf/hair.rs).

The Hair Info node reads two more vertex attributes of the tube (`node_tree.HAIR_INFO_ATTRIBUTES`),
computed on the curve's points as Cycles computes them and carried to the tube's rings:
"fibre" holds the intercept (the length of the control polygon from the root to the point over
the whole polygon's length; 0 on a curve of no length), that length, and the diameter (twice
the radius); "curve" the curve's index in its object (for particle hair, counted over all the
emitter's hair systems, as Cycles counts them: `PARTICLE_CURVE_INDEX`), from which the renderer
hashes Random. Between control points Cycles interpolates them linearly along the segment; the
tube's rings between the points of a Catmull-Rom curve have them interpolated along the spline
instead, alike where the points are evenly spaced.

This file runs inside the add-on and as the export child's script: it imports only bpy, the
standard library and node_tree.py.
"""

from __future__ import annotations

import contextlib
import math

import bpy

try:
    from .node_tree import HAIR_INFO_ATTRIBUTES
except ImportError:  # loaded by export.py as a top-level module in the export's child process
    from node_tree import HAIR_INFO_ATTRIBUTES

# Name of the Geometry Nodes group added for an export.
GROUP_NAME = "Photon points and curves"
# Object types whose geometry the group converts.
CONVERTED_TYPES = ("POINTCLOUD", "CURVES")
# Subdivisions of the icosphere standing for a point (5: 5120 triangles, stored once).
SPHERE_SUBDIVISIONS = 5
# Its scale: the icosphere of 5 subdivisions (an icosahedron's edges halved four times, the
# vertices pushed onto the unit sphere) has 0.99881 of the sphere's surface area.
SPHERE_SCALE = 1.0 / math.sqrt(0.99881)
# Sides of a hair's tube.
TUBE_SIDES = 8
# The tube's UV map: u runs from the curve's root (0) to its tip (1).
TUBE_UV_MAP = "UVMap"
# The curve parameter carried from the curve's points to the tube's vertices (removed after).
_CURVE_FACTOR = "photon_curve_factor"
# A curve attribute a particle hair's Curves object carries: its curve's index among all hair
# curves of the emitter (Cycles numbers them across the emitter's systems).
PARTICLE_CURVE_INDEX = "photon_particle_curve"


def tube_profile_radius(sides: int = TUBE_SIDES) -> float:
    """Circumradius of a regular `sides`-gon whose mean width is that of the unit circle (2)."""
    return math.pi / (sides * math.sin(math.pi / sides))


def _build_group():
    group = bpy.data.node_groups.new(GROUP_NAME, "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    material_socket = group.interface.new_socket("Material", in_out="INPUT",
                                                 socket_type="NodeSocketMaterial")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = group.nodes, group.links
    group_in, group_out = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    parts = nodes.new("GeometryNodeSeparateComponents")
    links.new(group_in.outputs["Geometry"], parts.inputs["Geometry"])
    join = nodes.new("GeometryNodeJoinGeometry")

    def finished(socket):
        """`socket`'s mesh shaded smooth with the object's material."""
        smooth = nodes.new("GeometryNodeSetShadeSmooth")
        links.new(socket, smooth.inputs["Geometry"])
        material = nodes.new("GeometryNodeSetMaterial")
        links.new(smooth.outputs["Geometry"], material.inputs["Geometry"])
        links.new(group_in.outputs["Material"], material.inputs["Material"])
        return material.outputs["Geometry"]

    # Points: one sphere, instanced on every point and scaled by its radius.
    sphere = nodes.new("GeometryNodeMeshIcoSphere")
    sphere.inputs["Subdivisions"].default_value = SPHERE_SUBDIVISIONS
    sphere.inputs["Radius"].default_value = 1.0
    scale = nodes.new("GeometryNodeTransform")
    links.new(sphere.outputs["Mesh"], scale.inputs["Geometry"])
    scale.inputs["Scale"].default_value = (SPHERE_SCALE,) * 3
    on_points = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(parts.outputs["Point Cloud"], on_points.inputs["Points"])
    links.new(finished(scale.outputs["Geometry"]), on_points.inputs["Instance"])
    links.new(nodes.new("GeometryNodeInputRadius").outputs[0], on_points.inputs["Scale"])

    # Curves: a tube swept along each, its profile scaled by the curve's radius.
    profile = nodes.new("GeometryNodeCurvePrimitiveCircle")
    profile.inputs["Resolution"].default_value = TUBE_SIDES
    profile.inputs["Radius"].default_value = tube_profile_radius()
    factor = nodes.new("GeometryNodeStoreNamedAttribute")
    factor.data_type, factor.domain = "FLOAT", "POINT"
    factor.inputs["Name"].default_value = _CURVE_FACTOR
    links.new(parts.outputs["Curve"], factor.inputs["Geometry"])
    links.new(nodes.new("GeometryNodeSplineParameter").outputs["Factor"],
              factor.inputs["Value"])
    tube = nodes.new("GeometryNodeCurveToMesh")
    links.new(_hair_info_stored(nodes, links, factor.outputs["Geometry"]), tube.inputs["Curve"])
    links.new(profile.outputs["Curve"], tube.inputs["Profile Curve"])
    links.new(nodes.new("GeometryNodeInputRadius").outputs[0], tube.inputs["Scale"])
    # The parameter along the curve as the tube's UV map (u), then dropped.
    read = nodes.new("GeometryNodeInputNamedAttribute")
    read.data_type = "FLOAT"
    read.inputs["Name"].default_value = _CURVE_FACTOR
    as_uv = nodes.new("ShaderNodeCombineXYZ")
    links.new(read.outputs["Attribute"], as_uv.inputs["X"])
    uv = nodes.new("GeometryNodeStoreNamedAttribute")
    uv.data_type, uv.domain = "FLOAT2", "CORNER"
    uv.inputs["Name"].default_value = TUBE_UV_MAP
    links.new(tube.outputs["Mesh"], uv.inputs["Geometry"])
    links.new(as_uv.outputs["Vector"], uv.inputs["Value"])
    dropped = nodes.new("GeometryNodeRemoveAttribute")
    dropped.inputs["Name"].default_value = _CURVE_FACTOR
    links.new(uv.outputs["Geometry"], dropped.inputs["Geometry"])
    # As an instance: the exporter writes a Curves object's instances, not its own geometry.
    tube_instance = nodes.new("GeometryNodeGeometryToInstance")
    links.new(finished(dropped.outputs["Geometry"]), tube_instance.inputs["Geometry"])

    for socket in (parts.outputs["Mesh"], parts.outputs["Instances"],
                   on_points.outputs["Instances"], tube_instance.outputs["Instances"]):
        links.new(socket, join.inputs["Geometry"])
    links.new(join.outputs["Geometry"], group_out.inputs["Geometry"])
    return group, material_socket.identifier


def _hair_info_stored(nodes, links, curves):
    """`curves` with the Hair Info attributes on their points (module documentation)."""
    def node(kind, **settings):
        made = nodes.new(kind)
        for key, value in settings.items():
            setattr(made, key, value)
        return made

    def math(operation, a, b):
        made = node("ShaderNodeMath", operation=operation)
        for socket, value in zip(made.inputs, (a, b)):
            if isinstance(value, float):
                socket.default_value = value
            else:
                links.new(value, socket)
        return made.outputs[0]

    position = node("GeometryNodeInputPosition").outputs[0]
    previous = node("GeometryNodeOffsetPointInCurve")
    previous.inputs["Offset"].default_value = -1
    previous_position = node("GeometryNodeFieldAtIndex", data_type="FLOAT_VECTOR",
                             domain="POINT")
    links.new(previous.outputs["Point Index"], previous_position.inputs["Index"])
    links.new(position, previous_position.inputs["Value"])
    step = node("ShaderNodeVectorMath", operation="DISTANCE")
    links.new(position, step.inputs[0])
    links.new(previous_position.outputs["Value"], step.inputs[1])
    # The root has no segment before it.
    step = math("MULTIPLY", step.outputs["Value"], previous.outputs["Is Valid Offset"])
    curve_index = node("GeometryNodeCurveOfPoint").outputs["Curve Index"]
    along = node("GeometryNodeAccumulateField", data_type="FLOAT", domain="POINT")
    links.new(step, along.inputs["Value"])
    links.new(curve_index, along.inputs[1])  # Group ID
    fibre = node("ShaderNodeCombineXYZ")
    # Blender's Divide gives 0 over 0, Cycles' intercept on a curve of no length.
    links.new(math("DIVIDE", along.outputs["Leading"], along.outputs["Total"]),
              fibre.inputs["X"])
    links.new(along.outputs["Total"], fibre.inputs["Y"])
    links.new(math("MULTIPLY", node("GeometryNodeInputRadius").outputs[0], 2.0),
              fibre.inputs["Z"])
    # A particle hair's index over its emitter's systems where given, else its own index.
    given = node("GeometryNodeInputNamedAttribute", data_type="FLOAT")
    given.inputs["Name"].default_value = PARTICLE_CURVE_INDEX
    index = node("GeometryNodeSwitch", input_type="FLOAT")
    links.new(given.outputs["Exists"], index.inputs["Switch"])
    links.new(curve_index, index.inputs["False"])
    links.new(given.outputs["Attribute"], index.inputs["True"])
    stored = curves
    for name, data_type, value in ((HAIR_INFO_ATTRIBUTES["fibre"], "FLOAT_VECTOR",
                                    fibre.outputs[0]),
                                   (HAIR_INFO_ATTRIBUTES["curve"], "FLOAT",
                                    index.outputs[0])):
        store = node("GeometryNodeStoreNamedAttribute", data_type=data_type, domain="POINT")
        store.inputs["Name"].default_value = name
        links.new(stored, store.inputs["Geometry"])
        links.new(value, store.inputs["Value"])
        stored = store.outputs["Geometry"]
    return stored


def _first_material(obj):
    """The first material of `obj`'s evaluated geometry, which Cycles renders its points and
    curves with (geometry made by Geometry Nodes has only the materials its nodes set; without
    any Cycles uses its default surface, and so does the export: no material)."""
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    return next((m for m in getattr(evaluated.data, "materials", ()) if m is not None), None)


@contextlib.contextmanager
def as_meshes(scene):
    """Within the block, the rendered Point Cloud and Curves objects of `scene` carry the
    conversion modifier (see the module documentation), and every hair particle system shown
    in renders has a Curves object of its strands (`hair_particles_as_curves`) that carries
    it too; all of it is removed after."""
    with hair_particles_as_curves(scene):
        owners = [obj for obj in scene.objects
                  if obj.type in CONVERTED_TYPES and not obj.hide_render]
        # Read before the modifier changes the evaluated geometry.
        materials = {obj.name: _first_material(obj) for obj in owners}
        with node_modifier_added(owners, _build_group) as added:
            for obj, modifier, material_input in added:
                if materials[obj.name] is not None:
                    modifier[material_input] = materials[obj.name]
            if added:
                bpy.context.view_layer.update()
            yield


def hair_radius(settings, fraction: float, last: bool) -> float:
    """Radius of a particle hair at `fraction` of its length, as Cycles reads the particle
    settings: half of Radius Scale × the root or tip diameter, between them by the strand
    shape (negative: thinner sooner), zero at the tip with Close Tip."""
    if last and settings.use_close_tip:
        return 0.0
    half = 0.5 * settings.radius_scale
    root, tip = half * settings.root_radius, half * settings.tip_radius
    t = 1.0 - fraction
    shape = settings.shape
    if shape < 0.0:
        t = t ** (1.0 + shape)
    elif shape > 0.0:
        t = t ** (1.0 / (1.0 - shape))
    return t * (root - tip) + tip


@contextlib.contextmanager
def hair_particles_as_curves(scene):
    """Within the block, each hair particle system rendered as strands (Path) on a rendered mesh
    object has a Curves object (world space, the system's material) holding its strands as Cycles
    renders them: the children in their render amount (and the parents only without children
    or with "Parents" on), 2^(render steps) segments, the radius of `hair_radius`. Read from
    the viewport's particle paths with the display settings set to the render ones for the time
    of the reading. An emitter whose only particles are such strands and that is not shown in
    renders (Show Emitter off) is hidden from the export, as Cycles hides it."""
    made, hidden = [], []
    try:
        for obj in [o for o in scene.objects if o.type == "MESH" and not o.hide_render]:
            systems = [m.particle_system for m in obj.modifiers
                       if m.type == "PARTICLE_SYSTEM" and m.show_render]
            strands = [s for s in systems
                       if s.settings.type == "HAIR" and s.settings.render_type == "PATH"]
            first = 0
            for system in strands:
                made.append(_strands(scene, obj, system, first))
                first += len(made[-1].data.curves)
            if strands and len(strands) == len(systems) and not obj.show_instancer_for_render:
                obj.hide_render = True
                hidden.append(obj)
        yield
    finally:
        for obj in hidden:
            obj.hide_render = False
        for curves_object in made:
            data = curves_object.data
            bpy.data.objects.remove(curves_object)
            bpy.data.hair_curves.remove(data)


def _strands(scene, obj, system, first_curve):
    """The Curves object of `system`'s strands, whose curves are numbered from `first_curve`
    (`PARTICLE_CURVE_INDEX`)."""
    settings = system.settings
    shown = ("display_step", "display_percentage", "child_percent")
    kept = {name: getattr(settings, name) for name in shown}
    try:
        settings.display_step = settings.render_step
        settings.display_percentage = 100
        settings.child_percent = settings.rendered_child_count
        bpy.context.view_layer.update()
        evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        psys = evaluated.particle_systems[system.name]
        keys = (1 << settings.render_step) + 1
        parents, children = len(psys.particles), len(psys.child_particles)
        # With children, the parents are rendered only when asked to ("Parents" in Render).
        first = parents if children and not settings.use_parent_particles else 0
        strands = [[tuple(psys.co_hair(object=evaluated, particle_no=i, step=k))
                    for k in range(keys)] for i in range(first, parents + children)]
    finally:
        for name, value in kept.items():
            setattr(settings, name, value)
        bpy.context.view_layer.update()
    curves = bpy.data.hair_curves.new(f"{obj.name} {system.name}")
    curves.add_curves([keys] * len(strands))
    positions, radii = [], []
    for strand in strands:
        lengths = [0.0]
        for a, b in zip(strand, strand[1:]):
            lengths.append(lengths[-1] + math.dist(a, b))
        total = lengths[-1] or 1.0
        for k, (point, length) in enumerate(zip(strand, lengths)):
            positions.extend(point)
            radii.append(hair_radius(settings, length / total, k == keys - 1))
    curves.position_data.foreach_set("vector", positions)
    curves.attributes.new("radius", "FLOAT", "POINT").data.foreach_set("value", radii)
    curves.attributes.new(PARTICLE_CURVE_INDEX, "FLOAT", "CURVE").data.foreach_set(
        "value", [float(first_curve + i) for i in range(len(strands))])
    slot = settings.material - 1
    if 0 <= slot < len(obj.material_slots) and obj.material_slots[slot].material is not None:
        curves.materials.append(obj.material_slots[slot].material)
    curves_object = bpy.data.objects.new(curves.name, curves)
    scene.collection.objects.link(curves_object)
    return curves_object


@contextlib.contextmanager
def node_modifier_added(objects, build_group):
    """Within the block each of `objects` (but linked ones) carries one more Geometry Nodes
    modifier whose group `build_group()` makes (once, returning the group and the identifier
    of its second input, or None); yields [(object, modifier, identifier)]. The modifiers and
    the group are removed afterwards and the view layer updated."""
    added, group = [], None
    try:
        if objects:
            group, identifier = build_group()
        for obj in objects:
            try:
                modifier = obj.modifiers.new(group.name, "NODES")
            except (RuntimeError, TypeError):  # linked data
                continue
            modifier.node_group = group
            added.append((obj, modifier, identifier))
        yield added
    finally:
        for obj, modifier, _ in added:
            obj.modifiers.remove(modifier)
        if group is not None:
            bpy.data.node_groups.remove(group)
        if added:
            bpy.context.view_layer.update()
