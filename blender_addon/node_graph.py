"""Reading Blender node trees as Cycles does: the output node it uses, and what feeds an input.

Every module of the add-on that follows links goes through `source` (or `upstream`, built on
it), so a tree means the same thing to the export, the pre-flight report and the preview:

- a muted link passes nothing: the input reads its own value;
- a muted node passes through it the input its internal links join to the output asked for
  (Blender's first matching input), or nothing when there is none;
- reroutes are followed, invalid links ignored;
- node groups are entered: a group node's output leads to the matching input of the group's
  active Group Output, and a Group Input inside leads back to the matching input of the group
  node that holds it. The group nodes on the way are kept as `Source.groups`.

It imports nothing but the standard library (it runs in the export's child process too).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Source:
    """Where an input takes its value from. `node` and `output` are the node and output socket
    that feed it, inside the group nodes `groups` (outermost first); without a link `node` and
    `output` are None and `socket` is the input whose own value is read: the input asked for,
    or the last input that passed a value on (a muted node's, a Group Output's, a group
    node's), past reroutes."""
    node: object | None
    output: object | None
    groups: tuple
    socket: object

    @property
    def linked(self) -> bool:
        return self.node is not None

    @property
    def key(self) -> tuple:
        """The node's identity within its group path (a node may be reached inside several
        group nodes using one group)."""
        return tuple(g.as_pointer() for g in self.groups) + (self.node.as_pointer(),)


def source(socket, groups: tuple = ()) -> Source:
    """What feeds input `socket` of a node inside the group nodes `groups` (module doc)."""
    value = socket  # the input whose value is read if the chain ends unlinked
    while True:
        links = [link for link in socket.links if not link.is_muted and link.is_valid]
        if not links:
            return Source(None, None, groups, value)
        node, output = links[0].from_node, links[0].from_socket
        if node.bl_idname == "NodeReroute":
            socket = node.inputs[0]
            continue
        if node.mute:
            passed = [link for link in node.internal_links if link.to_socket == output]
            if not passed:
                return Source(None, None, groups, value)
            socket = value = passed[0].from_socket
            continue
        if node.bl_idname == "ShaderNodeGroup":
            inner = group_output(node.node_tree) if node.node_tree is not None else None
            match = None if inner is None else _same_identifier(inner.inputs, output)
            if match is None:
                return Source(None, None, groups, value)
            socket = value = match
            groups = groups + (node,)
            continue
        if node.bl_idname == "NodeGroupInput":
            match = _same_identifier(groups[-1].inputs, output) if groups else None
            if match is None:
                return Source(None, None, groups, value)
            socket = value = match
            groups = groups[:-1]
            continue
        return Source(node, output, groups, value)


def linked_node(socket, groups: tuple = ()):
    """The node feeding `socket` (`source`), None when nothing does."""
    return source(socket, groups).node


def upstream(socket, groups: tuple = ()) -> list[Source]:
    """Every node that feeds `socket`, directly or through others (`source` on each input,
    enabled or not, of each node found), each once (per group path), in order of discovery."""
    found: dict[tuple, Source] = {}
    stack = [(socket, groups)]
    while stack:
        found_here = source(*stack.pop())
        if not found_here.linked or found_here.key in found:
            continue
        found[found_here.key] = found_here
        stack.extend((i, found_here.groups) for i in found_here.node.inputs if i.is_linked)
    return list(found.values())


def active_output(tree, bl_idname: str):
    """The output node of type `bl_idname` (ShaderNodeOutputMaterial, ...OutputWorld,
    ...OutputLight) that Cycles uses: the active one among those targeting all engines or
    Cycles, else the first of them; None without one."""
    outputs = [n for n in tree.nodes if n.bl_idname == bl_idname
               and getattr(n, "target", "ALL") in ("ALL", "CYCLES")]
    return next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)


def group_output(tree):
    """The Group Output node of a node group that gives the group its values."""
    outputs = [n for n in tree.nodes if n.bl_idname == "NodeGroupOutput"]
    return next((n for n in outputs if getattr(n, "is_active_output", False)),
                outputs[0] if outputs else None)


def _same_identifier(sockets, socket):
    return next((s for s in sockets if s.identifier == socket.identifier), None)
