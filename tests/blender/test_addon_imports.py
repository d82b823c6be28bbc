"""The add-on's modules import one another without a cycle, and the extension modules are leaves.

No bpy needed: each module of blender_addon/ is parsed with `ast` and every import of another
add-on module is collected, wherever it stands (module level, inside a function, or the
top-level form `import world` the export's child process falls back to).
"""

from __future__ import annotations

import ast
from pathlib import Path

ADDON = Path(__file__).resolve().parents[2] / "blender_addon"
# Modules that import nothing of the add-on's but the shared modules below: each writes one
# glTF extension from Blender data, and the export's child process loads them.
LEAVES = {"world", "lights", "camera", "motion"}
SHARED_MODULES = {"node_graph", "shared"}


def addon_imports(folder: Path = ADDON) -> dict[str, set[str]]:
    """For each module of `folder` (by name), the add-on modules it imports."""
    modules = {p.stem for p in folder.glob("*.py") if p.stem != "__init__"}
    graph = {}
    for name in sorted(modules):
        tree = ast.parse((folder / f"{name}.py").read_text(), filename=f"{name}.py")
        imported = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                if node.level == 1 and node.module is None:  # from . import a, b
                    imported.update(alias.name for alias in node.names)
                elif node.level == 1 or (node.level == 0 and node.module in modules):
                    imported.add(node.module.split(".")[0])  # from .a import x / from a import x
            elif isinstance(node, ast.Import):
                imported.update(alias.name for alias in node.names if alias.name in modules)
        graph[name] = (imported & modules) - {name}
    return graph


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle as a path [a, b, ..., a], or None."""
    state: dict[str, str] = {}  # "open" while on the current path, "done" after
    path: list[str] = []

    def visit(name):
        state[name] = "open"
        path.append(name)
        for other in sorted(graph.get(name, ())):
            if state.get(other) == "open":
                return path[path.index(other):] + [other]
            if other not in state:
                cycle = visit(other)
                if cycle:
                    return cycle
        path.pop()
        state[name] = "done"
        return None

    for name in sorted(graph):
        if name not in state:
            cycle = visit(name)
            if cycle:
                return cycle
    return None


def test_find_cycle_reports_a_cycle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None


def test_addon_modules_import_without_cycles():
    graph = addon_imports()
    assert "export" in graph and "preflight" in graph, sorted(graph)
    cycle = find_cycle(graph)
    assert cycle is None, "import cycle in blender_addon: " + " -> ".join(cycle)


def test_extension_modules_are_leaves():
    graph = addon_imports()
    for name in sorted(LEAVES):
        assert graph[name] <= SHARED_MODULES, (
            f"blender_addon/{name}.py imports {sorted(graph[name] - SHARED_MODULES)}; it may "
            f"import only {sorted(SHARED_MODULES)}")
    for name in sorted(SHARED_MODULES):
        assert not graph[name], f"blender_addon/{name}.py imports {sorted(graph[name])}"
