"""The import rules between packages (docs/interfaces.md): dependencies run one way,
``cli -> robot -> {cplus core, trajectory, nxt_link}``, and nothing imports the CLI; inside
``nxt_link``, ``host -> {wire, programs}`` and ``emulator -> {wire, programs}``."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


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


def test_the_rules_see_every_package():
    assert {rel.split("/")[1] for rel, _ in modules("cplus")} >= {"cli", "robot", "ground", "sat"}
    assert {rel.split("/")[1] for rel, _ in modules("nxt_link")} >= {"wire", "host", "emulator", "programs"}
    assert len(list(modules("trajectory"))) > 5 and len(list(modules("nxt_link"))) > 5


@pytest.mark.parametrize("rel, names", list(modules("trajectory")))
def test_trajectory_is_independent(rel, names):
    assert not top(names) & {"cplus", "nxt_link", "serial"}, rel


@pytest.mark.parametrize("rel, names", list(modules("nxt_link")))
def test_nxt_link_is_independent(rel, names):
    assert not top(names) & {"cplus", "trajectory", "numpy", "matplotlib", "shapely"}, rel
    if rel != "nxt_link/wire/serial_transport.py":
        assert "serial" not in top(names), rel


@pytest.mark.parametrize("rel, names", list(modules("cplus")))
def test_arrows_point_one_way(rel, names):
    in_cli = rel.startswith("cplus/cli/") or rel == "cplus/__main__.py"   # python -m cplus
    in_robot = rel.startswith("cplus/robot/")
    if not in_cli:
        assert not any(n == "cplus.cli" or n.startswith("cplus.cli.") for n in names), rel
    if not (in_cli or in_robot):
        assert not top(names) & {"trajectory", "nxt_link"}, rel
        assert not any(n == "cplus.robot" or n.startswith("cplus.robot.") for n in names), rel
    if rel != "cplus/sat/solver.py":
        assert "pysat.solvers" not in names, rel
    if rel.startswith("cplus/ground/"):
        assert not any(n.startswith("cplus.sat") for n in names), rel
    if rel in ("cplus/errors.py", "cplus/ast.py", "cplus/record.py"):   # the foundations
        assert not any(n.startswith("cplus.") and n not in ("cplus.errors", "cplus.record") for n in names), rel
    if rel == "cplus/record.py":
        assert not any(n.startswith("cplus.") for n in names), rel


@pytest.mark.parametrize("rel, names", list(modules("cplus")))
def test_unified_planning_stays_in_the_pddl_modules(rel, names):
    """unified-planning is the optional extra ``up``: only the PDDL front end and the engine use
    it, and the PDDL front end only inside functions (``cplus plan`` of a C+ file never needs it)."""
    if "unified_planning" in top(names):
        assert rel.startswith("cplus/pddl/") or rel == "cplus/up.py", rel
    if rel.startswith("cplus/pddl/"):
        tree = ast.parse((ROOT / rel).read_text(encoding="utf-8"))
        at_top = {a.name for n in tree.body if isinstance(n, ast.Import) for a in n.names}
        at_top |= {n.module for n in tree.body if isinstance(n, ast.ImportFrom) and n.module}
        assert "unified_planning" not in top(at_top), rel


#: The concerns of ``cplus/robot/`` and which others each may use: serving builds on the online
#: loop, the online loop re-plans with the offline task and streams through execution, and the
#: offline task and execution stand alone.
CONCERNS = {"offline": set(), "execution": set(), "online": {"offline", "execution"}, "serving": {"online"}}


def test_robot_is_split_by_concern():
    loose = {p.name for p in (ROOT / "cplus/robot").glob("*.py")}
    assert loose == {"__init__.py"}, loose
    packages = {p.name for p in (ROOT / "cplus/robot").iterdir() if (p / "__init__.py").is_file()}
    assert packages == set(CONCERNS), packages


@pytest.mark.parametrize("rel, names", [(r, n) for r, n in modules("cplus") if r.startswith("cplus/robot/")])
def test_robot_concerns_use_each_other_through_their_faces(rel, names):
    """A module may use another concern only as that concern's face (its ``__init__``) gives it,
    and only the concerns :data:`CONCERNS` allows; the face of :mod:`cplus.robot` is the offline
    task's."""
    parts = rel.split("/")
    own = parts[2] if len(parts) > 3 else None
    for name in names:
        if not name.startswith("cplus.robot."):
            continue
        other = name.split(".")[2]
        if other == own:
            continue
        allowed = {"offline"} if own is None else CONCERNS[own]
        assert other in allowed, f"{rel} uses {other} ({name})"
        assert name == f"cplus.robot.{other}", f"{rel} reaches into {name}: import it from cplus.robot.{other}"


#: The concerns of ``nxt_link/`` (after nxt-python's one package per concern) and which others
#: each may import: the wire stands alone; the brick programs' mailbox protocols use only the
#: wire; the host side drives bricks over the wire with those protocols; the emulator answers on
#: the wire and runs the programs. Neither the wire, the programs nor the emulator imports the
#: host side, and the host side never imports the emulator.
NXT_CONCERNS = {"wire": set(), "programs": {"wire"}, "host": {"wire", "programs"},
                "emulator": {"wire", "programs"}}


def test_nxt_link_is_split_by_concern():
    loose = {p.name for p in (ROOT / "nxt_link").glob("*.py")}
    assert loose == {"__init__.py"}, loose
    packages = {p.name for p in (ROOT / "nxt_link").iterdir() if (p / "__init__.py").is_file()}
    assert packages == set(NXT_CONCERNS), packages


def nxt_link_concern_violations(rel: str, names: set[str]) -> list[str]:
    """The imports of module ``rel`` (a path under ``nxt_link/``) that :data:`NXT_CONCERNS`
    forbids; every import counts, also those under ``TYPE_CHECKING`` and inside functions."""
    parts = rel.split("/")
    if len(parts) < 3:          # nxt_link/__init__.py, the face of all four
        return []
    own = parts[1]
    bad = []
    for name in names:
        if name == "nxt_link":  # the top face imports every concern
            bad.append(f"{rel} imports nxt_link itself (import from the concern's package)")
        elif name.startswith("nxt_link."):
            other = name.split(".")[1]
            if other != own and other not in NXT_CONCERNS[own]:
                bad.append(f"{rel} ({own}) imports {name} ({other})")
    return bad


@pytest.mark.parametrize("rel, names", list(modules("nxt_link")))
def test_nxt_link_concerns_import_one_way(rel, names):
    assert not nxt_link_concern_violations(rel, names)


def test_the_nxt_link_rules_catch_a_violating_import():
    assert nxt_link_concern_violations("nxt_link/wire/telegram.py", {"nxt_link.host.brick"})
    assert nxt_link_concern_violations("nxt_link/emulator/firmware.py", {"nxt_link.host.session"})
    assert nxt_link_concern_violations("nxt_link/programs/stream_protocol.py", {"nxt_link.emulator"})
    assert nxt_link_concern_violations("nxt_link/host/brick.py", {"nxt_link.emulator.world"})
    assert nxt_link_concern_violations("nxt_link/wire/clock.py", {"nxt_link"})
    assert not nxt_link_concern_violations("nxt_link/host/session.py",
                                           {"nxt_link.wire.telegram", "nxt_link.programs.stream_protocol"})
    assert not nxt_link_concern_violations("nxt_link/emulator/vm/nbc.py", {"nxt_link.programs"})


def test_no_import_cycles_between_modules():
    """Module-level imports (those that run at import time) form no cycle."""
    graph: dict[str, set[str]] = {}
    for package in ("cplus", "trajectory", "nxt_link"):
        for p in sorted((ROOT / package).rglob("*.py")):
            mod = ".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
            tree = ast.parse(p.read_text(encoding="utf-8"))
            deps = set()
            for node in tree.body:
                if isinstance(node, ast.ImportFrom) and node.module:
                    base = node.module if node.level == 0 else _relative(mod, p, node)
                    deps.add(base)
                    deps.update(f"{base}.{a.name}" for a in node.names)
                elif isinstance(node, ast.Import):
                    deps.update(a.name for a in node.names)
            graph[mod] = deps
    graph = {m: {d for d in deps if d in graph and d != m} for m, deps in graph.items()}
    state: dict[str, int] = {}

    def visit(m: str, path: list[str]) -> None:
        state[m] = 1
        for d in sorted(graph[m]):
            if state.get(d) == 1 and not m.startswith(d + "."):   # a package's __init__ importing its part
                raise AssertionError("import cycle: " + " -> ".join(path[path.index(d):] + [m, d])
                                     if d in path else f"import cycle through {m} -> {d}")
            if d not in state:
                visit(d, path + [m])
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m, [])


def _relative(mod: str, path: Path, node: ast.ImportFrom) -> str:
    parts = mod.split(".")
    if path.name != "__init__.py":
        parts = parts[:-1]
    parts = parts[:len(parts) - node.level + 1]
    return ".".join(parts + ([node.module] if node.module else []))
