"""The pre-flight report: what in the scene the export cannot carry to Photon yet.

`unsupported_features(scene, objects)` returns one message per feature, each naming the object,
material, world, light or node concerned, so that a render never drops something silently. The
engine reports each as a WARNING before exporting. A scene that Photon renders fully gives an
empty list, so the rules below only flag what really changes the image:

- shader nodes feeding a material's surface that Blender's glTF exporter does not map onto
  glTF's metallic-roughness material (Principled BSDF, Emission, image textures and the few
  other nodes it follows), unless the whole tree is one Photon evaluates itself (node_tree.py:
  it is then exported as PHOTON_material_nodes and nothing is dropped), and what of the world's
  node tree PHOTON_world does not carry (world.world_problems: anything but Background,
  Emission, Environment Texture, Sky Texture of any model, Mix Shader with a constant or
  "Is Camera Ray" factor and Add Shader);
- a Principled BSDF's Thin Film (iridescence) when its node tree is not one Photon evaluates
  (the tree route renders it; glTF carries no film), and under Blender 5 the film on a metallic
  Principled BSDF (Blender 5 puts it on the metal too, Photon as 4.5 does not); a Principled
  Hair BSDF of the Huang model (Photon's is Chiang's);
- volumes: a Volume shader tree Photon does not evaluate (node_tree.volume_tree: Principled
  Volume, Volume Scatter, Volume Absorption, Emission, Mix and Add Shader over the texture and
  converter nodes the surface trees have), Volume objects whose grids Photon cannot read, in
  the scene or instanced (volumes.problems, volumes.instanced_problems: missing files, grid
  types), and fluid domains whose smoke and fire Photon does not render
  (volumes.fluid_problems: no baked OpenVDB data at the frame, the "color" attribute, "heat"
  with noise);
- displacement linked into a material output (unless Photon evaluates the tree and its
  displacement, as bump, true displacement of the vertices or both: node_tree.py); Cycles'
  adaptive subdivision (its dicing rate: Photon displaces the mesh as the modifier leaves it);
- particles rendered as halos or paths (hair particle systems, Curves objects and point
  clouds are carried: points_curves.py);
- lights: what a light's node tree does beyond an Emission node's colour and strength (or a
  Light Falloff's Quadratic strength), shadows turned off;
- objects hidden from diffuse, glossy or transmission rays (Object > Visibility > Ray
  Visibility; camera and shadow visibility and holdout objects and collections are carried),
  'indirect only' collections;
- shadow linking with photon mapping (photons ignore it), past 63 linking collections;
- shadow catchers without a transparent film;
- render settings: Clamp Indirect with the photon method (its global-map and cache estimates
  are clamped whole);
- cameras: Cycles' custom (OSL) camera, depth of field with a panorama, a depth-of-field focus
  on a bone; with motion blur on, deforming objects other than meshes (armatures,
  animated shape keys of curves, surfaces, text: meshes' deformation is blurred).
"""

from __future__ import annotations

import bpy

from .camera import PANORAMAS
from .lights import light_linking, light_node_problems
from .motion import deforms
from .node_graph import active_output, source, upstream
from .node_tree import material_nodes, volume_tree
from .shared import GEOMETRY_TYPES, material_tree
from .volumes import fluid_domain, fluid_problems
from .volumes import instanced_problems as instanced_volume_problems
from .volumes import problems as volume_problems
from .world import world_problems, world_uses_nodes

# Node types (`node.type`) on the way to a material's Surface that the glTF exporter follows
# (reroutes, muted nodes and groups are passed through: node_graph.py). MIX, MATH and
# MIX_SHADER are checked separately.
MATERIAL_NODES = {
    "OUTPUT_MATERIAL", "BSDF_PRINCIPLED", "EMISSION", "TEX_IMAGE", "NORMAL_MAP", "UVMAP",
    "TEX_COORD", "MAPPING", "SEPARATE_COLOR", "SEPRGB", "VERTEX_COLOR", "ATTRIBUTE", "RGB",
    "VALUE", "ADD_SHADER", "BSDF_TRANSPARENT", "LIGHT_PATH",
}
# Ray visibility not carried (camera and shadow visibility are: PHOTON_object).
RAY_VISIBILITY = (("visible_diffuse", "diffuse"), ("visible_glossy", "glossy"),
                  ("visible_transmission", "transmission"))


def unsupported_features(scene, objects, view_layer=None) -> list[str]:
    """Messages for every feature of `scene` the export drops; `objects` are the objects being
    rendered (the render depsgraph's objects), `view_layer` the view layer rendered (default:
    the scene's first)."""
    if view_layer is None and len(scene.view_layers):
        view_layer = scene.view_layers[0]
    messages: list[str] = []
    materials = {}
    for obj in objects:
        messages += _object_features(obj)
        for slot in getattr(obj, "material_slots", ()):
            if slot.material is not None:
                materials.setdefault(slot.material.name, slot.material)
    messages += instanced_volume_problems(bpy.context.evaluated_depsgraph_get(),
                                          {getattr(obj, "original", obj).name for obj in objects
                                           if obj.type == "VOLUME"})
    for name in sorted(materials):
        messages += material_features(materials[name])
    if scene.world is not None:
        messages += world_features(scene.world)
    if scene.camera is not None:
        messages += _camera_features(scene.camera)
    rate = getattr(getattr(scene, "cycles", None), "volume_step_rate", 1.0)
    if abs(rate - 1.0) > 1e-6:
        messages.append(f"render settings: Volume Step Rate {rate:g} is not used: Photon "
                        f"tracks volumes exactly, without ray-marching steps")
    messages += light_path_features(scene)
    messages += light_linking_features(scene, objects)
    messages += shadow_catcher_features(scene, objects)
    for layer_collection in _layer_collections(view_layer):
        what = f"collection '{layer_collection.name}'"
        if layer_collection.exclude:
            continue
        if layer_collection.indirect_only:
            messages.append(f"{what}: 'indirect only' is not exported; its objects are seen "
                            f"directly too")
    if scene.render.use_motion_blur:
        rolling = getattr(getattr(scene, "cycles", None), "rolling_shutter_type", "NONE")
        if rolling != "NONE":
            messages.append("motion blur: the rolling shutter is not exported; every row is "
                            "exposed over the same shutter")
        # Meshes' deformation is exported (motion.deformation_recorded); other objects' not.
        deforming = [obj.name for obj in objects
                     if getattr(obj, "type", "") != "MESH" and deforms(obj)]
        if deforming:
            listed = ", ".join(f"'{name}'" for name in sorted(deforming)[:3])
            more = f" and {len(deforming) - 3} more" if len(deforming) > 3 else ""
            messages.append(f"motion blur: the deformation of objects other than meshes is not "
                            f"blurred (armatures or animated shape keys: {listed}{more}); "
                            f"meshes' deformation, moving objects and the camera are")
    return messages


def light_path_features(scene) -> list[str]:
    """What of Render > Light Paths Photon does not render as Cycles does (Clamp Direct and
    Clamp Indirect, the caustics switches and Filter Glossy are carried:
    export.render_extension)."""
    cycles = getattr(scene, "cycles", None)
    if cycles is None:
        return []
    messages = []
    method = getattr(getattr(scene, "photon", None), "method", "")
    if method == "PHOTON" and float(getattr(cycles, "sample_clamp_indirect", 0.0)) > 0.0:
        messages.append("render settings: with the photon method, Clamp Indirect holds each "
                        "global photon-map and cache estimate as one contribution (caustic "
                        "photons are clamped as Cycles' paths): light of small, very bright "
                        "lamps after two diffuse bounces that Cycles' clamp removes stays (the "
                        "path tracer clamps as Cycles)")
    return messages


def shadow_catcher_features(scene, objects) -> list[str]:
    """What of Blender's shadow catchers Photon does not render: catchers without a
    transparent film (rendered as the objects they are)."""
    # Light objects report is_shadow_catcher too; only geometry catches shadows.
    catchers = sorted(obj.name for obj in objects if obj.type in GEOMETRY_TYPES
                      and getattr(obj, "is_shadow_catcher", False))
    if not catchers:
        return []
    names = ", ".join(f"'{name}'" for name in catchers[:3])
    messages = []
    if not scene.render.film_transparent:
        messages.append(f"shadow catcher ({names}): only rendered with Film > Transparent; "
                        f"Photon renders it as the object it is")
    return messages


def light_linking_features(scene, objects) -> list[str]:
    """What of Blender's light and shadow linking Photon does not render (lights.light_linking
    carries the rest): more sets than Photon numbers, and shadow linking with photon mapping,
    whose photons ignore it."""
    emitters, _, problems = light_linking(objects)
    messages = list(problems)
    method = getattr(getattr(scene, "photon", None), "method", "")
    shadowed = sorted(name for name, sets in emitters.items() if "blocker_set" in sets)
    if shadowed and method != "PATH":
        names = ", ".join(f"'{name}'" for name in shadowed[:3])
        messages.append(f"shadow linking ({names}): photons ignore it (the light they bounce "
                        f"is still shadowed by every object); the path tracer (Method: Path "
                        f"Tracing) renders it in full")
    return messages


def _object_features(obj) -> list[str]:
    messages = []
    what = f"object '{obj.name}'"
    if obj.type == "VOLUME":
        messages += volume_problems(obj)
    elif fluid_domain(obj) is not None:
        messages += fluid_problems(obj, bpy.context.scene.frame_current)
    elif obj.type == "LIGHT":
        messages += light_features(obj)
    for modifier in getattr(obj, "modifiers", ()):
        adaptive = getattr(getattr(obj, "cycles", None), "use_adaptive_subdivision", False) \
            or getattr(modifier, "use_adaptive_subdivision", False)
        if modifier.type == "SUBSURF" and adaptive:
            messages.append(f"{what}: adaptive subdivision (Cycles' dicing rate) is not "
                            f"rendered; Photon subdivides by the modifier's Render levels")
    for system in getattr(obj, "particle_systems", ()):
        # Objects and collections go as instances, hair strands (PATH) as tubes.
        carried = ("OBJECT", "COLLECTION", "NONE", "PATH" if system.settings.type == "HAIR"
                   else "OBJECT")
        if system.settings.render_type not in carried:
            messages.append(f"{what}: particle system '{system.name}' rendered as "
                            f"{system.settings.render_type} is not exported (objects and "
                            f"collections are)")
    if obj.type in GEOMETRY_TYPES:
        hidden = [ray for prop, ray in RAY_VISIBILITY if not getattr(obj, prop, True)]
        if hidden:
            messages.append(f"{what}: ray visibility is not exported (it is hidden from "
                            f"{', '.join(hidden)} rays in Blender, visible to all in Photon)")
    return messages


def light_features(obj) -> list[str]:
    light, messages = obj.data, []
    what = f"light '{obj.name}'"
    messages += [f"{what}: {problem}" for problem in light_node_problems(light)]
    if not getattr(light, "use_shadow", True):
        messages.append(f"{what}: 'Cast Shadow' off is not exported; it casts shadows in Photon")
    hidden = [ray for prop, ray in RAY_VISIBILITY if not getattr(obj, prop, True)]
    if hidden:
        messages.append(f"{what}: ray visibility is exported only as seen or not by scattered "
                        f"rays (it is hidden from {', '.join(hidden)} rays in Blender): rays "
                        f"do not meet the lamp, but it still lights every surface in Photon")
    return messages


def material_features(material) -> list[str]:
    """Messages for the parts of `material`'s node tree that the export drops."""
    tree = material_tree(material)
    if tree is None:
        return []
    what = f"material '{material.name}'"
    output = active_output(tree, "ShaderNodeOutputMaterial")
    if output is None:
        return []
    messages = []
    extension = material_nodes(material)[0]
    evaluated = extension is not None
    feeding = [] if evaluated else upstream(output.inputs["Surface"])
    for found in feeding:
        reason = _material_node_reason(found)
        if reason:
            messages.append(f"{what}: {found.node.bl_label} node '{found.node.name}' {reason}")
    for found in feeding:
        node = found.node
        film = node.inputs.get("Thin Film Thickness") if node.type == "BSDF_PRINCIPLED" else None
        if film is not None and (source(film, found.groups).linked or film.default_value > 0.0):
            messages.append(f"{what}: Principled BSDF '{node.name}': Thin Film is not rendered "
                            f"(the node tree is not evaluated, and glTF carries no film); the "
                            f"surface renders without its iridescence")
    messages += _volume_features(material, output)
    displacement = output.inputs.get("Displacement")
    displaced = source(displacement).node if displacement is not None else None
    if displaced is not None and not (evaluated and ("displacement" in extension
                                                     or "displace" in extension)):
        messages.append(f"{what}: displacement ('{displaced.name}') is not exported")
    return messages


def _volume_features(owner, output) -> list[str]:
    """What of the volume shader on a material's or world's output Photon does not render."""
    tree, problems = volume_tree(owner, output)
    messages = [f"{p}; the volume is not rendered" for p in problems]
    settings = getattr(owner, "cycles", None)
    if tree is not None and settings is not None:
        what = f"material '{owner.name}'"
        rate = getattr(settings, "volume_step_rate", 1.0)
        if abs(rate - 1.0) > 1e-6:
            messages.append(f"{what}: Volume Step Rate {rate:g} is not used: Photon tracks "
                            f"volumes exactly, without ray-marching steps (as Cycles does "
                            f"from Blender 5)")
        if getattr(settings, "volume_interpolation", "LINEAR") == "CUBIC":
            messages.append(f"{what}: cubic volume interpolation is rendered as linear")
    return messages


def _material_node_reason(found) -> str:
    """Why the exporter drops the node `found` (a `node_graph.Source`); '' when it does not."""
    node = found.node
    kind = node.type
    if kind == "ATTRIBUTE" and node.attribute_type != "GEOMETRY":
        return (f"reads an attribute of type {node.attribute_type.title().replace('_', ' ')}, "
                f"which glTF's metallic-roughness material does not carry (Photon reads it "
                f"where it evaluates the node tree); the material renders without it")
    if kind == "BSDF_HAIR_PRINCIPLED" and getattr(node, "model", "") == "HUANG":
        return ("uses the Huang model, which Photon does not render (its Principled Hair is "
                "the Chiang model); the material renders without it")
    if kind in MATERIAL_NODES:
        return ""
    if kind == "MIX" and getattr(node, "blend_type", "") == "MULTIPLY":
        return ""  # a colour factor times a texture
    if kind == "MATH" and node.operation == "MULTIPLY":
        return ""  # a factor times a texture channel
    if kind == "MIX_SHADER":
        shaders = [mixed.node.type for mixed in (source(s, found.groups) for s in node.inputs[1:3])
                   if mixed.linked]
        if sum(t not in ("BSDF_TRANSPARENT", "EMISSION") for t in shaders) <= 1:
            return ""  # alpha (Transparent BSDF) or emission mixed in: the exporter maps both
        return "mixes two shaders; the export keeps only one of them"
    if kind == "MIX":
        return f"(blend mode {node.blend_type}) is not exported; the material renders without it"
    if kind == "MATH":
        return (f"(operation {node.operation}) is not exported; the material renders "
                f"without it")
    return "is not exported; the material renders without it"


def world_features(world) -> list[str]:
    if not world_uses_nodes(world):
        return []
    output = active_output(world.node_tree, "ShaderNodeOutputWorld")
    if output is None:
        return []
    return world_problems(world) + _volume_features(world, output)


def _camera_features(camera_object) -> list[str]:
    camera, messages = camera_object.data, []
    what = f"camera '{camera_object.name}'"
    if camera.type == "PANO" and camera.panorama_type not in PANORAMAS:
        messages.append(f"{what}: the {camera.panorama_type} panoramic projection is not "
                        f"exported; Photon renders a perspective view")
    elif camera.type == "CUSTOM":
        messages.append(f"{what}: Cycles' custom (OSL) camera is not exported; Photon renders "
                        f"a perspective view")
    elif camera.type == "PANO" and camera.dof.use_dof:
        messages.append(f"{what}: depth of field is not rendered with a panoramic camera")
    if camera.dof.use_dof and camera.dof.focus_object is not None and camera.dof.focus_subtarget:
        messages.append(f"{what}: depth of field focuses on the origin of "
                        f"'{camera.dof.focus_object.name}', not on its bone "
                        f"'{camera.dof.focus_subtarget}'")
    return messages


def _layer_collections(view_layer):
    """Every layer collection of `view_layer` below its root, parents before children; none
    below an excluded one."""
    if view_layer is None:
        return []
    found, stack = [], list(view_layer.layer_collection.children)
    while stack:
        layer = stack.pop(0)
        found.append(layer)
        if not layer.exclude:
            stack.extend(layer.children)
    return found
