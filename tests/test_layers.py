"""The package's layers, written down: a subpackage imports only from layers below its own (module
level and inside functions alike), so the data path reads one way, parameters -> models ->
estimators -> evaluation -> report, and no two packages import each other."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "roadbank"

#: lowest first; a unit may import from any unit of a lower layer
LAYERS = (
    {"__version__", "constants", "runtime"},             # version string; physical constants; process settings
    {"params", "units", "defaults", "cache", "vehicles"},
    {"signals", "models"},
    {"io", "estimators", "sim"},
    {"vehicle", "evaluation", "identification", "export"},
    {"report", "mapping"},
    {"campaign", "validation", "faults"},
    {"fleet", "tuning"},
    {"bench"},
    {"cli", "__main__"},
)
LEVEL = {u: k for k, layer in enumerate(LAYERS) for u in layer}


def _unit(path: Path) -> str:
    parts = path.relative_to(SRC).parts
    return parts[0].removesuffix(".py")


def imports(path: Path) -> set[str]:
    """The roadbank units (subpackages or top-level modules) a source file imports from."""
    tree = ast.parse(path.read_text())
    pkg = list(path.relative_to(SRC).parts[:-1]) if path.is_relative_to(SRC) else ["estimators"]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[:len(pkg) - (node.level - 1)]
                mod = base + (node.module.split(".") if node.module else [])
                out.add(mod[0] if mod else node.names[0].name)
            elif node.module and node.module.split(".")[0] == "roadbank" and "." in node.module:
                out.add(node.module.split(".")[1])
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("roadbank."):
                    out.add(a.name.split(".")[1])
    return out


FILES = sorted(p for p in SRC.rglob("*.py") if p.name != "__init__.py" or p.parent != SRC)


def test_every_unit_has_a_layer():
    units = {_unit(p) for p in FILES}
    assert units <= set(LEVEL), sorted(units - set(LEVEL))


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(SRC)))
def test_imports_go_down_the_layers(path):
    me = _unit(path)
    up = sorted(u for u in imports(path) - {me} if LEVEL.get(u, -1) >= LEVEL[me])
    assert not up, f"{path.relative_to(SRC)} ({me}, layer {LEVEL[me]}) imports {up} from its own layer or above"


def test_the_check_sees_a_violation(tmp_path):
    bad = tmp_path / "x.py"
    bad.write_text("def f():\n    from roadbank.cli import main\n    from ..report import figures\n")
    assert {"cli", "report"} <= imports(bad)
