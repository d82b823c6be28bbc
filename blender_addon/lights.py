"""PHOTON_light: a light object as Cycles renders it, and what of its node tree is not carried.

The glTF exporter writes point, spot and sun lights as KHR_lights_punctual lights, drops area
lights and gets a light's colour wrong when it has a node tree; `light_extension` writes what
Cycles renders (colour and power with the node tree's Emission node, lamp radius, spot cone,
sun angle, area lights), `light_node_problems` names what it does not carry (for the
pre-flight report). It imports only node_graph.py of the add-on's modules: it runs in the export's
child process too.
"""

from __future__ import annotations

import contextlib
import math

try:
    from .node_graph import active_output, linked_node, source
except ImportError:  # loaded by export.py as a top-level module in the export's child process
    from node_graph import active_output, linked_node, source


# Blackbody colours of the lights whose Temperature switch `temperature_hidden` turned off for
# the export, by light name.
HIDDEN_TEMPERATURE_COLORS: dict[str, list[float]] = {}


@contextlib.contextmanager
def temperature_hidden(scene):
    """Within the block, the scene's lights have their Temperature switch off (and
    `light_tint` reads their blackbody colour from `HIDDEN_TEMPERATURE_COLORS`): Blender 5.0's
    glTF exporter fails on a light with Temperature on (it multiplies a channel by the whole
    colour), and PHOTON_light carries the colour anyway. Linked lights are left as they are."""
    lights = {obj.data for obj in scene.objects
              if obj.type == "LIGHT" and getattr(obj.data, "use_temperature", False)
              and obj.data.library is None}
    try:
        for light in lights:
            HIDDEN_TEMPERATURE_COLORS[light.name_full] = [float(c) for c in
                                                          light.temperature_color[:3]]
            light.use_temperature = False
        yield
    finally:
        for light in lights:
            if light.name_full in HIDDEN_TEMPERATURE_COLORS:
                light.use_temperature = True
                del HIDDEN_TEMPERATURE_COLORS[light.name_full]


def light_extension(obj) -> dict:
    """PHOTON_light for a light object: its colour and power as Cycles combines them (the
    light's colour x its blackbody colour when "Temperature" is on x the colour of the Emission
    node of its node tree; power x 2^exposure x the node's strength), which the glTF exporter
    gets wrong with a node tree (it keeps only the node's colour); plus what glTF cannot say:
    point/spot radius, Soft Falloff and which rays see the lamp (camera, also for a sun's
    disc; scattered rays when diffuse, glossy and transmission visibility are all on), Cycles'
    exact spot cone (size and blend), sun angle, area lights."""
    light = obj.data
    color, strength = light_tint(light)
    scale = 2.0 ** float(getattr(light, "exposure", 0.0)) * strength
    if light.type in ("POINT", "SPOT"):
        data = {"radius": float(light.shadow_soft_size), "power": float(light.energy) * scale,
                "color": color, "soft_falloff": bool(getattr(light, "use_soft_falloff", True)),
                "visible_camera": bool(getattr(obj, "visible_camera", False)),
                "visible_bounces": all(bool(getattr(obj, prop, True)) for prop in
                                       ("visible_diffuse", "visible_glossy",
                                        "visible_transmission"))}
        if light.type == "SPOT":
            data["spot_size"] = float(light.spot_size)
            data["spot_blend"] = float(light.spot_blend)
        return data
    if light.type == "SUN":
        return {"angle": float(light.angle), "strength": float(light.energy) * scale,
                "color": color, "visible_camera": bool(getattr(obj, "visible_camera", False))}
    if light.type != "AREA":
        return {}
    size = float(light.size)
    size_y = float(light.size_y) if light.shape in ("RECTANGLE", "ELLIPSE") else size
    power = float(light.energy) * scale
    if not getattr(light, "normalize", True):
        # Without "normalize" Blender's power is per square metre; Photon always normalises.
        area = size * size_y * (math.pi / 4.0 if light.shape in ("DISK", "ELLIPSE") else 1.0)
        power *= area
    return {"type": "area", "shape": light.shape, "size": size, "size_y": size_y,
            "power": power, "color": color, "spread": float(light.spread),
            "visible_camera": bool(obj.visible_camera)}


def light_tint(light) -> tuple[list[float], float]:
    """(colour, strength factor) of a light as Cycles renders it: light.color x its blackbody
    colour (when use_temperature is on) x the Emission node's colour, and the node's strength
    (or the strength of a Light Falloff node's Quadratic output feeding it). What the node tree
    does beyond that is named by `light_node_problems` (the pre-flight report)."""
    color = [float(c) for c in light.color[:3]]
    temperature = HIDDEN_TEMPERATURE_COLORS.get(light.name_full)
    if temperature is None and getattr(light, "use_temperature", False):
        temperature = light.temperature_color[:3]
    if temperature is not None:
        color = [c * float(t) for c, t in zip(color, temperature)]
    emission = light_emission_node(light)
    if emission is None:
        return color, 1.0
    node_color = emission.inputs["Color"]
    if not source(node_color).linked:
        color = [c * float(n) for c, n in zip(color, node_color.default_value[:3])]
    elif _blackbody_temperature(node_color) is not None:
        blackbody = blackbody_color(light, _blackbody_temperature(node_color))
        color = [c * b for c, b in zip(color, blackbody)]
    strength_input = emission.inputs["Strength"]
    strength = float(strength_input.default_value)
    feeding = linked_node(strength_input)
    if feeding is not None:
        falloff_strength = feeding.inputs.get("Strength") if feeding.type == "LIGHT_FALLOFF" \
            else None
        strength = 1.0
        if falloff_strength is not None and not source(falloff_strength).linked:
            strength = float(falloff_strength.default_value)
    return color, strength


def _blackbody_temperature(socket):
    """The temperature of a Blackbody node (its input unlinked) feeding `socket`, else None."""
    node = linked_node(socket)
    if node is None or node.type != "BLACKBODY" or source(node.inputs["Temperature"]).linked:
        return None
    return float(node.inputs["Temperature"].default_value)


def blackbody_color(light, kelvin: float) -> list[float]:
    """Blender's blackbody colour of `kelvin`, read from the light's own temperature colour
    (Light.temperature_color, Blender's table) by setting its temperature for a moment."""
    saved = light.temperature, light.use_temperature
    try:
        light.temperature, light.use_temperature = kelvin, True  # the colour needs both
        return [float(c) for c in light.temperature_color[:3]]
    finally:
        light.temperature, light.use_temperature = saved


def _light_output(light):
    """The Light Output Cycles uses in a light's node tree (read when use_nodes is on); None
    without one."""
    tree = light.node_tree if getattr(light, "use_nodes", False) else None
    return None if tree is None else active_output(tree, "ShaderNodeOutputLight")


def light_emission_node(light):
    """The Emission node feeding the active Light Output of a light's node tree; None without
    one."""
    output = _light_output(light)
    node = None if output is None else linked_node(output.inputs["Surface"])
    return node if node is not None and node.type == "EMISSION" else None


def light_node_problems(light) -> list[str]:
    """What a light's node tree does that `light_tint` does not carry ([] for none)."""
    if light.node_tree is None or not getattr(light, "use_nodes", False):
        return []
    output = _light_output(light)
    shader = None if output is None else linked_node(output.inputs["Surface"])
    if shader is None:
        return ["its node tree has no shader on the Light Output (Cycles renders it black)"]
    emission = light_emission_node(light)
    if emission is None:
        return [f"the {shader.bl_label} node '{shader.name}' on its output is not exported "
                f"(only an Emission node is)"]
    problems = []
    color = linked_node(emission.inputs["Color"])
    if color is not None and _blackbody_temperature(emission.inputs["Color"]) is None:
        problems.append(f"the {color.bl_label} node '{color.name}' driving the emission colour "
                        f"is not exported")
    strength = source(emission.inputs["Strength"])
    if strength.linked:
        node = strength.node
        if node.type != "LIGHT_FALLOFF":
            problems.append(f"the {node.bl_label} node '{node.name}' driving the emission "
                            f"strength is not exported")
        elif strength.output.name != "Quadratic":
            problems.append(f"Light Falloff '{node.name}': its {strength.output.name} output "
                            f"is not exported (only Quadratic, the physical falloff, is)")
        elif source(node.inputs["Strength"]).linked or source(node.inputs["Smooth"]).linked \
                or float(node.inputs["Smooth"].default_value) != 0.0:
            problems.append(f"Light Falloff '{node.name}': a linked strength or a smooth "
                            f"falloff is not exported")
    return problems


# Light sets Photon numbers (Cycles' light sets: set 0 holds every object).
MAX_LINK_SETS = 63


def _linked_states(collection) -> dict:
    """The link state ('INCLUDE' or 'EXCLUDE') of every object in a light or shadow linking
    `collection`, by object name: an object's own entry, or the state of the child collection
    entry it is reached through (the outermost one wins)."""
    states: dict = {}

    def visit(coll, inherited, seen):
        if coll.name in seen:
            return
        seen = seen | {coll.name}
        # collection_objects and collection_children hold the link states of `objects` and
        # `children`, entry for entry.
        for obj, entry in zip(coll.objects, getattr(coll, "collection_objects", ())):
            states.setdefault(obj.name, inherited or entry.light_linking.link_state)
        for child, entry in zip(coll.children, getattr(coll, "collection_children", ())):
            visit(child, inherited or entry.light_linking.link_state, seen)

    visit(collection, None, frozenset())
    return states


def _in_set(name: str, states: dict) -> bool:
    """Blender's rule: with included objects, only those (less the excluded ones); with only
    excluded ones, every object but those."""
    if any(state == "INCLUDE" for state in states.values()):
        return states.get(name) == "INCLUDE"
    return states.get(name) != "EXCLUDE"


def light_linking(objects) -> tuple[dict, dict, list[str]]:
    """Blender's light and shadow linking of `objects` as numbered sets: ({emitter name:
    {"receiver_set": k, "blocker_set": k}}, {object name: {"not_lit_by": [k...],
    "not_blocking": [k...]}}, problems). Emitters sharing a collection share its set; past
    MAX_LINK_SETS collections the rest are not linked (named in problems)."""
    objects = list(objects)
    emitters: dict = {}
    sets = {"receiver_set": {}, "blocker_set": {}}
    problems = []
    for obj in objects:
        linking = getattr(obj, "light_linking", None)
        if linking is None:
            continue
        for key, prop in (("receiver_set", "receiver_collection"),
                          ("blocker_set", "blocker_collection")):
            coll = getattr(linking, prop, None)
            if coll is None:
                continue
            numbered = sets[key]
            if coll.name not in numbered:
                if len(numbered) >= MAX_LINK_SETS:
                    problems.append(f"object '{obj.name}': more than {MAX_LINK_SETS} light "
                                    f"linking collections; '{coll.name}' is not linked")
                    continue
                numbered[coll.name] = (len(numbered) + 1, _linked_states(coll))
            emitters.setdefault(obj.name, {})[key] = numbered[coll.name][0]
    receivers: dict = {}
    for obj in objects:
        data = {}
        for key, out in (("receiver_set", "not_lit_by"), ("blocker_set", "not_blocking")):
            left_out = [k for k, states in sets[key].values() if not _in_set(obj.name, states)]
            if left_out:
                data[out] = sorted(left_out)
        if data:
            receivers[obj.name] = data
    return emitters, receivers, problems
