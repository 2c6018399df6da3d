"""The import rules between packages (docs/interfaces.md): dependencies run one way."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
GLUE = {"cplus/cli.py", "cplus/pipeline.py", "cplus/execute.py"}


def imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.add(node.module)
    return out


def modules(package: str):
    for p in sorted((ROOT / package).rglob("*.py")):
        yield str(p.relative_to(ROOT)), imports(p)


def top(names: set[str]) -> set[str]:
    return {n.split(".")[0] for n in names}


@pytest.mark.parametrize("rel, names", list(modules("trajectory")))
def test_trajectory_is_independent(rel, names):
    assert not top(names) & {"cplus", "nxt_link", "serial"}, rel


@pytest.mark.parametrize("rel, names", list(modules("nxt_link")))
def test_nxt_link_is_independent(rel, names):
    assert not top(names) & {"cplus", "trajectory", "numpy", "matplotlib", "shapely"}, rel
    if rel != "nxt_link/serial_transport.py":
        assert "serial" not in top(names), rel


@pytest.mark.parametrize("rel, names", list(modules("cplus")))
def test_the_planner_core_does_not_reach_the_robots(rel, names):
    if rel not in GLUE:
        assert not top(names) & {"trajectory", "nxt_link"}, rel
    if rel != "cplus/sat/solver.py":
        assert "pysat.solvers" not in names, rel
    if rel.startswith("cplus/ground/"):
        assert not any(n.startswith("cplus.sat") for n in names), rel
    if rel in ("cplus/errors.py", "cplus/ast.py"):
        assert not any(n.startswith("cplus.") and n != "cplus.errors" for n in names), rel
