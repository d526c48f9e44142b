"""The layers of ARCHITECTURE.md, enforced: a package imports only from its own layer's packages
below it, never from a layer above (function-level imports included), and modules keep to size."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "pipette_cli"

# lowest first; a package may import from any package in an earlier layer (and from itself)
LAYERS: list[set[str]] = [
    {"__init__", "errors"},
    {"plugins"},
    {"resources"},
    {"templating", "specs"},
    {"assets", "llm"},
    {"registry", "evaluators"},
    {"sim"},
    {"skills"},
    {"demos"},
    {"augment", "lerobot", "serving"},
    {"evaluation"},
    {"authoring", "demo"},
    {"agent"},
    {"cli", "envs"},
]
LAYER = {package: depth for depth, packages in enumerate(LAYERS) for package in packages}
MAX_LINES = 500


def _package(path: Path) -> str:
    return path.relative_to(ROOT).parts[0].removesuffix(".py")


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, imported pipette_cli package) for every import in the module, at any depth."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        names = []
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "pipette_cli":
                out.append((node.lineno, parts[1] if len(parts) > 1 else "__init__"))
    return out


MODULES = sorted(ROOT.rglob("*.py"))


def test_every_package_has_a_layer() -> None:
    packages = {_package(p) for p in MODULES}
    assert packages - set(LAYER) == set(), "add new packages to ARCHITECTURE.md and LAYERS"


def test_imports_point_down_the_layers() -> None:
    wrong = []
    for path in MODULES:
        own = _package(path)
        for line, target in _imports(path):
            if target != own and target in LAYER and LAYER[target] >= LAYER[own]:
                wrong.append(
                    f"{path.relative_to(ROOT.parent)}:{line}: {own} (layer {LAYER[own]}) imports "
                    f"{target} (layer {LAYER[target]})"
                )
    assert wrong == []


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(ROOT)))
def test_modules_stay_small(path: Path) -> None:
    lines = len(path.read_text().splitlines())
    assert lines <= MAX_LINES, f"{path.relative_to(ROOT.parent)} has {lines} lines; split it by concept"


def test_the_layer_check_sees_a_wrong_import(tmp_path: Path) -> None:
    module = tmp_path / "m.py"
    module.write_text("def f():\n    from pipette_cli.cli.main import app\n")
    assert _imports(module) == [(2, "cli")]
