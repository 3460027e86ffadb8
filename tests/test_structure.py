"""The harness's import structure: no two modules of physval/ import each other, directly or
in a circle, and no import runs from a lower layer back up (commands -> readings -> core ->
report kit). The one circle left is the core's with physval/faults.py (the core's context
plants faults), until planting moves into the adapter layer."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LAYERS = ("physval.commands", "physval.readings", "physval.core", "physval.report")  # top to bottom
LEFT = "physval.faults"  # the one circle left: core/context.py imports it, it imports the core


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted((ROOT / "physval").rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _imports(name: str, path: Path, modules: dict) -> set[str]:
    """The physval modules `name` imports anywhere in its file (in functions too, and under
    TYPE_CHECKING): `from a.b import c` names a.b.c where that is a module, else a.b."""
    found = set()
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[:len(package.split(".")) - node.level + 1] + ([base] if base else []))
            found |= {f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names}
    return {m for m in found if m in modules and m != name}


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def _circles(graph: dict[str, set[str]]) -> list[set[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(comp)

    for v in graph:
        if v not in index:
            visit(v)
    return out


def _layer(name: str) -> int | None:
    return next((i for i, top in enumerate(LAYERS) if name == top or name.startswith(top + ".")), None)


def test_no_two_modules_import_each_other():
    circles = _circles(_graph())
    assert all(LEFT in c for c in circles), [sorted(c) for c in circles if LEFT not in c]


def test_no_import_runs_from_a_lower_layer_back_up():
    up = [(a, b) for a, targets in _graph().items() for b in targets
          if _layer(a) is not None and _layer(b) is not None and _layer(b) < _layer(a)]
    assert not up


def test_the_graph_sees_the_imports_it_checks():
    """The checks above would pass on a graph that saw nothing: it sees the layers' imports."""
    graph = _graph()
    assert "physval.readings.checks" in graph["physval.readings.results"]
    assert "physval.report" in graph["physval.readings.checks"]
    assert "physval.core.tolerance" in graph["physval.core.deviations"]
    assert any(LEFT in c for c in _circles(graph))  # the circle left is seen
