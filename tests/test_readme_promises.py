"""Numbers and defaults the README promises, each held to what the user reads (the README's
sentence, the option's help) and to what the program does: a change of either side fails here.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = " ".join(" ".join(p.read_text(encoding="utf-8") for p in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]).split())  # the README and docs/, lines joined
PAYLOAD = ROOT / "domains" / "payload" / "payload.cp"
MAILBOT = ROOT / "domains" / "mailbot" / "mailbot.cp"


def says(pattern: str) -> re.Match[str]:
    m = re.search(pattern, README)
    assert m, f"the README no longer says {pattern!r}"
    return m


# -- the refinement's solver -----------------------------------------------------------------


def test_the_refinement_solves_with_minisat_unless_told(monkeypatch):
    says(r"a robot task's refinement uses `minisat22` unless told")
    says(r"MiniSat, the refinement's solver unless `--solver` says otherwise")
    from cplus.cli.plan import build_parser
    assert "minisat22 for a robot task's refinement" in " ".join(build_parser().format_help().split())
    import importlib

    from cplus.robot import RobotTask, refine
    refine_module = importlib.import_module("cplus.robot.offline.refine")
    used: list[str] = []
    real = refine_module.QuerySession

    class Spy(real):  # type: ignore[misc, valid-type]
        def __init__(self, theory, query, solver, *args, **kw):
            used.append(solver)
            super().__init__(theory, query, solver, *args, **kw)

    monkeypatch.setattr(refine_module, "QuerySession", Spy)
    task = RobotTask.load(str(PAYLOAD), str(PAYLOAD.parent / "scene.toml"))
    assert refine(task, "0").status.value == "found"
    assert refine(task, "0", solver="glucose4").status.value == "found"
    assert used == ["minisat22", "glucose4"]


# -- cplus run: emulated bricks 10 times faster, no latency; ticks of 10 to 10000 ms ------------


def run_args(tmp_path, *extra: str):
    from cplus.cli.run import build_parser
    return build_parser().parse_args([str(PAYLOAD), "--out", str(tmp_path / "out"), *extra])


def test_cplus_run_runs_emulated_bricks_on_simulated_time_without_latency(tmp_path):
    says(r"Emulated bricks run on \*simulated time\* without Bluetooth latency unless asked otherwise")
    from cplus.cli.run import _validate, build_parser
    assert "default: on simulated time" in " ".join(build_parser().format_help().split())
    args = run_args(tmp_path)
    _validate(args)
    assert args.time_scale is None and args.latency is False     # None: the simulated clock
    args = run_args(tmp_path, "--time-scale", "1", "--latency")
    _validate(args)
    assert args.time_scale == 1.0 and args.latency is True


@pytest.mark.parametrize("step_time, points, ok", [
    ("10", "1", True), ("10.001", "1", False), ("20", "2", True), ("20.002", "2", False),
    ("0.01", "1", True), ("0.009", "1", False)])
def test_cplus_run_takes_ticks_from_10_to_10000_ms(tmp_path, step_time, points, ok):
    lo, hi = says(r"a whole number of milliseconds from (\d+) to (\d+)").groups()
    assert (lo, hi) == ("10", "10000")
    from cplus.cli.common import CliError
    from cplus.cli.run import _validate
    args = run_args(tmp_path, "--step-time", step_time, "--points-per-step", points)
    if ok:
        _validate(args)
    else:
        with pytest.raises(CliError, match=rf"it must be a whole number of milliseconds from {lo} to {hi}$"):
            _validate(args)


def test_the_brick_program_takes_ticks_up_to_10000_ms():
    from nxt_link.host.execution import SetpointStream
    from nxt_link.wire.errors import SetpointError
    assert SetpointStream("r1", ("A",), 10000, ((0,),)).tick_ms == 10000
    assert SetpointStream("r1", ("A",), 10, ((0,),)).tick_ms == 10
    for tick in (10001, 9):
        with pytest.raises(SetpointError, match=r"10\.\.10000"):
            SetpointStream("r1", ("A",), tick, ((0,),))


# -- the rxe cache ------------------------------------------------------------------------------


def test_nbc_output_is_cached_under_the_users_cache_folder(tmp_path, monkeypatch):
    says(r"`cplus brick` compiles `cplus_follow.nxc` with nbc once \(cached in `~/.cache/cplus/rxe`\)")
    from nxt_link.emulator.vm import nbc
    compiled: list[Path] = []

    def compile_nxc(source, **_kw):
        compiled.append(Path(source))
        return nbc.Compiled(b"RXE" + Path(source).read_bytes()[:4], "symbols")

    monkeypatch.setattr(nbc, "nbc_path", lambda: "/usr/bin/nbc")
    monkeypatch.setattr(nbc, "_nbc_version", lambda _nbc: "nbc 1.2")
    monkeypatch.setattr(nbc, "compile_nxc", compile_nxc)
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    assert nbc.cache_dir() == tmp_path / ".cache" / "cplus" / "rxe"
    first = nbc.cached_compile(nbc.follower_source())
    second = nbc.cached_compile(nbc.follower_source())
    assert compiled == [nbc.follower_source()]  # once
    assert first.path is not None and first.path.parent == tmp_path / ".cache" / "cplus" / "rxe"
    assert first.path.name.startswith("cplus_follow-") and first.path.suffix == ".rxe"
    assert second.path == first.path and (second.rxe, second.symbols) == (first.rxe, first.symbols)
    # a new nbc version compiles again; $XDG_CACHE_HOME moves the cache
    monkeypatch.setattr(nbc, "_nbc_version", lambda _nbc: "nbc 1.3")
    assert nbc.cached_compile(nbc.follower_source()).path != first.path and len(compiled) == 2
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert nbc.cache_dir() == tmp_path / "xdg" / "cplus" / "rxe"
    assert nbc.cached_compile(nbc.follower_source()).path.parent == tmp_path / "xdg" / "cplus" / "rxe"


# -- cplus serve's default address --------------------------------------------------------------


def test_cplus_serve_listens_on_127_0_0_1_7070_when_no_channel_is_given(monkeypatch):
    address = says(r"the default when no channel is given: `([0-9.]+):(\d+)`")
    assert address.groups() == ("127.0.0.1", "7070")
    from cplus.cli import serve
    assert "the default when no channel is given: 127.0.0.1:7070" in " ".join(
        serve.build_parser().format_help().split())
    calls: list[tuple] = []
    monkeypatch.setattr(serve, "_run", lambda *args, **kw: calls.append(args) or 0)
    assert serve.main(serve.build_parser().parse_args([str(MAILBOT)])) == 0
    assert calls[0][0].listen == ("127.0.0.1", 7070)           # _run takes the checked options
    assert serve.main(serve.build_parser().parse_args([str(MAILBOT), "--listen", "127.0.0.1:0"])) == 0
    assert calls[1][0].listen == ("127.0.0.1", 0)


# -- the README's first two commands ------------------------------------------------------------

def test_the_readme_starts_with_the_main_job_and_the_test_command():
    """The first two command blocks: one installs and runs the payload pipeline, one installs
    and runs the suite as CI does (.ci/run ends with the same pytest command)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```sh\n(.*?)\n```", text, re.S)
    run, test = blocks[0], blocks[1]
    assert text.index("```sh") < text.index("\n## ")          # before any section
    assert "pip install ." in run and run.endswith("cplus run domains/payload/payload.cp")
    assert "pip install -e '.[test]'" in test and test.endswith("python -m pytest -n 2")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert re.search(r"^python -m pytest (-q )?-n 2$", ci, re.M)
