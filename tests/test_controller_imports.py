"""The controller package's import graph has no cycle (imports inside functions included)."""

from __future__ import annotations

import ast
from pathlib import Path

CONTROLLER = Path(__file__).resolve().parents[1] / "controller"


def _module_name(path: Path) -> str:
    rel = path.relative_to(CONTROLLER.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _import_graph() -> dict[str, set[str]]:
    """Module -> controller modules it imports anywhere in its body (package inits left out)."""
    modules = {_module_name(p): p for p in CONTROLLER.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            deps.update(t for t in targets if t in modules and t != name)
        graph[name] = deps
    return graph


def _cycle(graph: dict[str, set[str]], skip: set[str]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for d in sorted(graph.get(n, ())):
            if d in skip:
                continue
            if state.get(d) == 1:
                return [*stack[stack.index(d) :], d]
            if d not in state and (found := visit(d)):
                return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if n not in state and n not in skip and (found := visit(n)):
            return found
    return None


def test_graph_sees_the_known_edges() -> None:
    graph = _import_graph()
    assert "controller.interface" in graph["controller.baseline"]
    assert "controller.interface" in graph["controller.runtime"]
    # function-level imports count: the registry builds the cores inside its constructors
    assert {"controller.baseline", "controller.runtime"} <= graph["controller.registry"]


def test_no_import_cycle_in_the_controller_package() -> None:
    graph = _import_graph()
    # Package __init__ files are left out: ``controller`` only re-exports names, and the
    # offline ``controller.design`` package's helpers (design/observer.py calls back into
    # design/__init__.py from inside a function) are not part of the runtime cores.
    skip = {"controller", "controller.design"}
    assert _cycle(graph, skip=skip) is None, _cycle(graph, skip=skip)


def test_interface_imports_no_implementation() -> None:
    assert _import_graph()["controller.interface"] == set()


def test_cycle_detector_finds_a_cycle() -> None:
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}, skip=set()) == ["a", "b", "c", "a"]
