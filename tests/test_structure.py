"""The harness's import structure: no two modules of physval/ import each other, directly or
in a circle, and no import runs from a lower layer back up (commands -> readings -> core ->
report kit). The core knows nothing of physval/faults.py (a planted fault reaches it through
the adapter layer's hook, adapters/planting.py), and no module of the harness (nor the
hook) reads another object's private state."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LAYERS = ("physval.commands", "physval.readings", "physval.core", "physval.report")  # top to bottom
FAULTS = "physval.faults"  # the catalogue of planted faults: above the core, which never imports it


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
    assert not circles, [sorted(c) for c in circles]


def test_the_core_does_not_import_the_faults():
    """Planting is the adapter layer's (adapters/planting.py): no module of the core or the
    report kit imports physval/faults.py, directly or through another module."""
    graph = _graph()

    def reach(name, seen):
        for m in graph[name] - seen:
            seen.add(m)
            reach(m, seen)
        return seen

    low = [m for m in graph if _layer(m) is not None and _layer(m) >= LAYERS.index("physval.core")]
    assert not [m for m in low if FAULTS in reach(m, set())]


# Private names of other objects the harness may read: the standard library's own, and a
# named tuple's public methods and fields (named with a leading underscore so as not to clash
# with its field names: collections.namedtuple).
ALLOWED_PRIVATE = {"os._exit"}
NAMED_TUPLE_API = {"_replace", "_fields", "_asdict", "_make", "_field_defaults"}


def _private_reads(path: Path) -> list[str]:
    """`x._name` in a file where x is not self or cls (a dunder is no private name)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__"):
            if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                continue
            text = ast.unparse(node)
            if text not in ALLOWED_PRIVATE and node.attr not in NAMED_TUPLE_API:
                out.append(f"{path}:{node.lineno}: {text}")
    return out


def test_nothing_outside_an_adapter_reads_its_private_state():
    """The harness, the fault catalogue and the planting hook go through adapters' public
    methods (a planted change is the adapter's own Simulation.plant)."""
    files = [*sorted((ROOT / "physval").rglob("*.py")), ROOT / "adapters" / "planting.py"]
    assert not [r for f in files for r in _private_reads(f)]


def test_the_private_read_check_sees_one(tmp_path):
    """The check above would pass on a reader that saw nothing: it sees a reach into an
    engine's world and lets self, cls and the allowed names be."""
    probe = tmp_path / "probe.py"
    probe.write_text("import os\ndef f(self, sim):\n    os._exit(0)\n    return self._x, sim._world\n")
    assert _private_reads(probe) == [f"{probe}:4: sim._world"]


def test_the_graph_sees_the_imports_it_checks():
    """The checks above would pass on a graph that saw nothing: it sees the layers' imports."""
    graph = _graph()
    assert "physval.readings.checks" in graph["physval.readings.results"]
    assert "physval.report" in graph["physval.readings.checks"]
    assert "physval.core.tolerance" in graph["physval.core.deviations"]
    assert "physval.core" in graph[FAULTS]  # the catalogue runs planted engines through the core
