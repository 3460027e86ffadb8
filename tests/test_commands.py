"""The front door: every command is one module of physval.commands with the same two public
names, physval.cli dispatches to each (so no command can be left unregistered, as `real`
once was), and the layers import only downwards."""
from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

from physval import cli

ROOT = Path(__file__).resolve().parent.parent


def test_every_command_module_is_in_the_dispatch_table():
    modules = {p.stem for p in (ROOT / "physval" / "commands").glob("*.py")} - {"__init__", "options"}
    assert {m.replace("_", "-") for m in modules} == set(cli.COMMANDS)
    for name, module in cli.COMMANDS.items():
        assert module == f"physval.commands.{name.replace('-', '_')}"


@pytest.mark.parametrize("command", list(cli.COMMANDS))
def test_each_command_dispatches_through_main(command, monkeypatch, capsys):
    """main() parses the command's own options and calls its module's run() with them."""
    module = importlib.import_module(cli.COMMANDS[command])
    assert callable(module.add_parser) and callable(module.run)
    called = []
    monkeypatch.setattr(module, "run", lambda args: called.append(args) or 0)
    argv = {"known": ["known", "reference"], "check-case": ["check-case", "x.py"], "compare": ["compare", "a", "b"],
            "versions": ["versions", "mujoco", "3.3.7", "4.0.0"],
            "parity": ["parity", "mujoco", "mujoco-warp"]}.get(command, [command])
    assert cli.main(argv) == 0
    assert len(called) == 1 and called[0].command == command
    assert cli.main([command, "--help"]) == 0
    assert f"usage: physval {command}" in capsys.readouterr().out


def test_version_and_help():
    assert cli.main(["--version"]) == 0
    assert cli.main(["--help"]) == 0


def test_a_removed_or_misspelt_option_is_one_line(capsys):
    assert cli.main(["run", "--no-such-option"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unrecognized arguments: --no-such-option" in err[0]


# --- the layers ---------------------------------------------------------------------------------

def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names.add(node.module)
            names |= {f"{node.module}.{a.name}" for a in node.names}
    return names


def _files(*folders: str):
    for folder in folders:
        yield from sorted((ROOT / folder).rglob("*.py"))


# what each layer must not import: commands sit below the CLI, readings below the commands,
# the core below the readings; the scene vocabulary (cases) and the engines (adapters)
# know nothing of the harness, and the reference implementation nothing of the rest
FORBIDDEN = {
    "physval/commands": ("physval.cli",),
    "physval/readings": ("physval.cli", "physval.commands"),
    "physval/core": ("physval.cli", "physval.commands", "physval.readings"),
    "cases": ("physval",),
    "adapters": ("physval",),
    "reference_impl": ("physval", "cases", "adapters"),
}


@pytest.mark.parametrize("folder", list(FORBIDDEN))
def test_layers_import_only_downwards(folder):
    bad = []
    for path in _files(folder):
        for name in _imports(path):
            if any(name == f or name.startswith(f + ".") for f in FORBIDDEN[folder]):
                bad.append(f"{path.relative_to(ROOT)} imports {name}")
    assert not bad, bad
