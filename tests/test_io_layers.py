"""The modules of roadbank.io import each other one way: no circle, counting the imports at module
level and inside functions alike (the shared types and the format registry sit below the formats,
the formats below ``load_log`` / ``stream_log``)."""

from __future__ import annotations

import ast
from pathlib import Path

IO = Path(__file__).resolve().parents[1] / "src" / "roadbank" / "io"


def io_imports(path: Path, siblings: set[str]) -> set[str]:
    """The sibling modules (``from .x import ...`` / ``from . import x``) a module imports, anywhere in it."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            if node.module:
                out.add(node.module.split(".")[0])
            else:
                out |= {a.name for a in node.names}
    return (out & siblings) - {path.stem}


def graph(folder: Path) -> dict[str, set[str]]:
    """Module name -> the sibling modules it imports, for every ``*.py`` of ``folder``."""
    files = sorted(folder.glob("*.py"))
    names = {p.stem for p in files}
    return {p.stem: io_imports(p, names) for p in files}


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """The import circles of ``g``: its strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(g.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    return found


def test_io_has_no_import_circle():
    g = graph(IO)
    assert {"log", "readers", "stream", "kitti", "types", "formats"} <= set(g)
    assert cycles(g) == []


def test_format_modules_sit_below_the_entry_points():
    g = graph(IO)
    for fmt in ("kitti", "comma2k19", "can", "ros"):
        assert not g[fmt] & {"log", "readers", "stream"}, (fmt, sorted(g[fmt]))
    assert not g["types"] & {"log", "readers", "stream", "kitti", "comma2k19", "can", "ros"}
    assert g["formats"] == set()


def test_the_check_sees_a_circle(tmp_path):
    (tmp_path / "a.py").write_text("from .b import x\n")
    (tmp_path / "b.py").write_text("def f():\n    from .c import y\n")      # inside a function
    (tmp_path / "c.py").write_text("from . import a\n")
    (tmp_path / "d.py").write_text("from .a import z\nimport numpy\n")
    g = graph(tmp_path)
    assert g == {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert cycles(g) == [["a", "b", "c"]]
    (tmp_path / "c.py").write_text("import os\n")
    assert cycles(graph(tmp_path)) == []
