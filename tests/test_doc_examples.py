"""Every example in README.md and docs/*.md runs as printed (issue 31).

What is an example:

* a ```` ```sh ```` block: each line is a command (a trailing ``\\`` continues it; ``#`` lines
  are comments);
* a transcript: a block whose first line is ``$ COMMAND``; the lines up to the next ``$ ``
  are what the command prints, standard output and standard error as a terminal shows them
  (a line ``...`` stands for any lines); in a ``cplus shell`` session the ``?- GOAL`` lines are
  what was typed (its standard input; from a pipe there is no prompt);
* a ```` ```python ```` block that imports something (the others are signatures and records),
  except docs/api.md's ``>>>`` blocks, which tests/cplus/test_api_doc.py runs as doctests.

Each block runs in a scratch folder of its own holding a copy of ``domains/`` and
``bench/data/`` (never in the tree), its commands in order, as a user pasting them would
(``bash -e -o pipefail``). A command must exit 0 (or the code in ``EXIT``) and a transcript's
output must be what it shows, after normalising only what must vary: times, temporary paths,
pseudo-terminals, and the test's scratch folder.  Commands that serve until stopped
(``SERVES``) must come up and stop cleanly on SIGINT.

What is not run is listed in ``NOT_RUN``, in one place, with the reason for each; an example
not listed that does not run fails, and an entry that no longer matches an example fails too,
so the list only shrinks.  ``SLOW`` blocks are marked ``slow``.
"""
from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

# -- what is not run, and why: one place ----------------------------------------------------

NOT_RUN: dict[str, str] = {
    # installing
    "python3 -m venv .venv && . .venv/bin/activate && pip install .":
        "installs the package into a new virtual environment (minutes, the network); the test runs in one",
    "python3 -m venv .venv && . .venv/bin/activate && pip install . && cplus run domains/payload/payload.cp":
        "installs the package into a new virtual environment (minutes, the network); `cplus run` of the "
        "payload task is run by the README's next section's example",
    "sudo apt-get install -y nbc && python3 -m venv .venv && . .venv/bin/activate && pip install -e '.[test]' "
    "&& python -m pytest -n 2":
        "installs system packages as root and runs the whole suite",
    "sudo apt-get install -y ros-core python3-rospy python3-actionlib python3-genpy python3-genmsg "
    "python3-actionlib-msgs":
        "installs system packages as root",
    # real bricks
    "cplus online domains/delivery/delivery.cp --brick robot=/dev/rfcomm0 --log run.jsonl":
        "a real brick on /dev/rfcomm0",
    "cplus online domains/payload/payload.cp --brick r1=/dev/rfcomm0 --brick r2=/dev/rfcomm1":
        "real bricks on /dev/rfcomm0 and /dev/rfcomm1",
    "cplus execute out/trajectory.json --brick r1=/dev/rfcomm0 --brick r2=/dev/rfcomm1":
        "real bricks on /dev/rfcomm0 and /dev/rfcomm1",
    "from nxt_link import Brick, SerialTransport, SetpointStream, execute_streams":
        "real bricks on /dev/rfcomm0 and /dev/rfcomm1 (the same calls on emulated bricks: docs/api.md)",
    # Ray, ROS
    "cplus batch jobs.toml --ray=auto": "an existing Ray cluster",
    "cplus serve domains/mailbot/mailbot.cp --ros": "ROS needs a master (roscore) and the ROS environment",
    "import actionlib, rospy": "ROS needs a master (roscore) and the ROS environment",
    "roscore -p 11311 &  export ROS_MASTER_URI=http://127.0.0.1:11311 ROS_HOSTNAME=127.0.0.1":
        "starts a ROS master for the rest of the session",
    "roscore -p 11311 &": "starts a ROS master for the rest of the session",
    "export ROS_MASTER_URI=http://127.0.0.1:11311 ROS_HOSTNAME=127.0.0.1": "the ROS master's session",
    "export PYTHONPATH=$PWD/cplus/robot/serving/ros": "ROS's command-line tools, in a ROS session",
    "rostopic pub -1 /cplus_serve/goal cplus_msgs/ServeActionGoal '{goal: {request: \"deliver(office3,office2)\"}}'":
        "ROS's command-line tools: a master, and a `cplus serve --ros` to talk to",
    "rostopic echo /cplus_serve/feedback": "ROS's command-line tools: a master, and a `cplus serve --ros` to talk to",
    "rostopic pub -1 /cplus_serve/cancel actionlib_msgs/GoalID '{id: \"\"}'":
        "ROS's command-line tools: a master, and a `cplus serve --ros` to talk to",
    # clients that need what is not a dependency
    "printf '{\"request\": \"deliver(office3,office2)\"}\\n' | nc -q 30 127.0.0.1 7070":
        "netcat is not a dependency (the Python line of the same block runs)",
    "printf '{\"request\": \"deliver(office3,office2)\"}\\n' | socat -t 30 - TCP:127.0.0.1:7070":
        "socat is not a dependency (the Python line of the same block runs)",
    # long runs
    "cplus batch bench/data --timeout 60": "the benchmark instances: minutes (docs/benchmarks.md)",
    "python -m doctest -o ELLIPSIS -o NORMALIZE_WHITESPACE docs/api.md":
        "tests/cplus/test_api_doc.py runs these examples with the same flags",
    "nice -n 10 python bench/mutants.py nxt_link/wire/framing.py": "mutation testing: minutes per module",
    "nice -n 10 python bench/mutants.py cplus/sat/cnf.py --sample 60": "mutation testing: minutes per module",
    "python bench/mutants.py nxt_link/wire/framing.py --report": "the survivors of an earlier mutation run",
    "python bench/busy.py 12 -- python -m pytest -q -n 2": "the whole suite beside 12 busy processes: an hour",
    "python bench/busy.py 12 -- python -m pytest -q -n 2 tests/test_interrupts.py tests/test_signals.py "
    "tests/test_serve_stress_*.py tests/nxt_link/test_brick_faults.py tests/cplus/test_parallel.py "
    "tests/cplus/test_batch.py tests/test_execute.py tests/test_run_*.py tests/test_online_*.py":
        "a third of the suite beside 12 busy processes: many minutes",
    # sketches: names that come from their context
    "from nxt_link import Brick, EmulatorConfig, SetpointStream, execute_streams":
        "a sketch: `streams` as in the block before it",
    "import trajectory as tj": "a sketch: `states` is a plan's states (docs/api.md runs the whole way)",
    "from cplus.api import Domain\nfrom cplus.robot.serving.reactive import Server, ServerSettings":
        "serves until server.stop(); docs/api.md's serving examples run",
}
"""Command (or a python block's first lines) -> why it is not run."""

KNOWN_BROKEN: dict[str, str] = {}
"""Command -> the branch that fixes it: expected to fail here, and the block is an xfail with
that reason (the block's other commands still run); once it runs, the test fails until the
entry goes."""

EXIT: dict[str, int] = {
    "cplus shell": 2,   # docs/shell.md: from a pipe a failed command ('query zz.') exits 2; at a terminal 0
}
"""Command -> its exit code, where it is not 0 (as the page says)."""

SERVES: dict[str, str] = {
    "cplus brick --name r1 --link r1.tty": r"r1\.tty$",
    "cplus brick --name r1 --drop 0.1 --disconnect-after 40": r"^\S+tty\S*$",
    "cplus brick --name r1 --link /tmp/r1.tty": r"r1\.tty$",
    "cplus brick --name r1 --program my_program.rxe": r"^\S+tty\S*$",
    "cplus brick --name robot --world domains/delivery/world.toml": r"^\S+tty\S*$",
    "cplus brick --name r1 --stall A@2.5": r"^\S+tty\S*$",
    "cplus serve domains/mailbot/mailbot.cp --listen 127.0.0.1:7070 --log run.jsonl": r"listening on",
    "cplus serve domains/mailbot/line.cp --robot domains/mailbot/robot.toml --listen 127.0.0.1:7070":
        r"listening on",
}
"""Command that serves until stopped -> the line (regular expression) that says it is up.
It must come up, then stop on SIGINT with exit code 0 (or one in ``STOPPED``)."""

STOPPED: dict[str, set[int]] = {
    # docs/serve.md, "Stopping": a run that has not ended 1.2 s after the signal is ended by the
    # watchdog, exit 130; on a loaded machine an emulated robot's action may outlast that
    "cplus serve": {0, 130},
}
"""A serving command's first two words -> the exit codes it may stop with on SIGINT."""


def _stopped_as_documented(command: str, code: int) -> bool:
    return code in STOPPED.get(" ".join(command.split()[:2]), {0})

NXC_PROGRAM = 'task main() { TextOut(0, LCD_LINE1, "hello"); Wait(100000); }\n'


@dataclass
class Setup:
    """What a block needs that its page gives in prose: files, a command first, a server."""

    files: dict[str, str] = field(default_factory=dict)           # path -> text
    before: list[str] = field(default_factory=list)               # commands, run first
    server: str | None = None                                     # served while the block runs
    server_ready: str = ""                                        # its up line (regex)


def _setup_for(first: str) -> Setup | None:
    """The setup of the block whose first command (or python line) is ``first``."""
    if first.startswith("cplus execute out/trajectory.json"):   # docs/robot.md: a plan's trajectory, a program
        return Setup(files={"prog.nxc": NXC_PROGRAM},
                     before=["mkdir -p out", "cplus plan domains/payload/payload.cp --trajectory out/trajectory.json",
                             "nbc -O=my_program.rxe prog.nxc"])
    if first == "cplus batch jobs.toml":
        return Setup(files={"jobs.toml": _block_text("docs/batch.md", "toml")})
    if first.startswith("printf '{\"request\""):
        return Setup(server="cplus serve domains/mailbot/mailbot.cp --listen 127.0.0.1:7070",
                     server_ready="listening on")
    if first.startswith("import nxt.locator"):
        return Setup(server="cplus brick --name r1 --link r1.tty", server_ready=r"r1\.tty$")
    return None


SLOW = {
    "cplus run domains/payload/payload.cp",
    "cplus batch jobs.toml",
    "cplus online domains/delivery/delivery.cp",
    "cplus online domains/payload/payload.cp --stall r1:A@4+2 --log arms.jsonl",
    "cplus online domains/payload/payload.cp --stall r1:A@2+1 --log arms.jsonl; cplus replay arms.jsonl --animate arms.gif",
    "cplus execute out/trajectory.json --scene domains/payload/scene.toml --log out/exec.json --plot out/fig5.png",
    "cplus serve domains/mailbot/mailbot.cp --script domains/mailbot/table1.jsonl",
}
"""A block with one of these commands is marked ``slow`` (seconds to a minute each)."""


# -- extraction ------------------------------------------------------------------------------


@dataclass
class Command:
    text: str                          # as printed, without a trailing comment
    line: int                          # its line in the page
    stdin: str = ""                    # what was typed (a shell session's goals)
    output: list[str] | None = None    # what the page shows it prints (a transcript)


@dataclass
class Block:
    page: str
    line: int
    kind: str                          # "sh", "transcript", "python"
    commands: list[Command]
    source: str = ""                   # a python block's text

    @property
    def id(self) -> str:
        return f"{self.page}:{self.line}"

    @property
    def first(self) -> str:
        return self.commands[0].text


FENCE = re.compile(r"^(\s*)```(\S*)\s*$")
COMMENT = re.compile(r"\s{2,}#\s.*$|\s{2,}#$")


def fenced_blocks(page: Path) -> Iterator[tuple[int, str, list[str]]]:
    """(line of the opening fence, info string, the lines inside) for every fenced block."""
    lines = page.read_text(encoding="utf-8").split("\n")
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if m:
            indent, info, start = len(m.group(1)), m.group(2), i
            i += 1
            body = []
            while i < len(lines) and not FENCE.match(lines[i]):
                body.append(lines[i][indent:] if lines[i][:indent].strip() == "" else lines[i])
                i += 1
            yield start + 1, info, body
        i += 1


def _strip_comment(text: str) -> str:
    return COMMENT.sub("", text).rstrip()


def _sh_commands(start: int, body: list[str]) -> list[Command]:
    commands: list[Command] = []
    pending: list[str] = []
    for k, raw in enumerate(body):
        line = raw.rstrip()
        if not pending and (not line.strip() or line.lstrip().startswith("#")):
            continue
        if line.endswith("\\"):
            pending.append(line[:-1].rstrip())
            continue
        pending.append(_strip_comment(line))
        commands.append(Command(" ".join(p.strip() for p in pending), start + 1 + k))
        pending = []
    return commands


def _transcript(start: int, body: list[str]) -> list[Command]:
    commands: list[Command] = []
    for k, line in enumerate(body):
        if line.startswith("$ "):
            commands.append(Command(_strip_comment(line[2:]), start + 1 + k, output=[]))
        elif line.startswith("?- "):
            commands[-1].stdin += line[3:] + "\n"
        else:
            commands[-1].output.append(line)   # type: ignore[union-attr]
    return commands


def examples() -> list[Block]:
    blocks: list[Block] = []
    for page in PAGES:
        name = page.relative_to(ROOT).as_posix()
        for line, info, body in fenced_blocks(page):
            if info == "sh":
                blocks.append(Block(name, line, "sh", _sh_commands(line, body)))
            elif info in ("", "console", "text") and body and body[0].startswith("$ "):
                blocks.append(Block(name, line, "transcript", _transcript(line, body)))
            elif info == "python" and not any(b.lstrip().startswith(">>>") for b in body) \
                    and any(re.match(r"\s*(import|from)\s", b) for b in body):
                text = "\n".join(body) + "\n"
                blocks.append(Block(name, line, "python", [Command(_python_key(text), line)], source=text))
    return blocks


def _python_key(text: str) -> str:
    """How NOT_RUN names a python block: its first line, or its first two where the first is
    as common as ``from cplus.api import Domain``."""
    lines = [ln for ln in text.split("\n") if ln.strip()]
    return "\n".join(lines[:2]) if lines[0] == "from cplus.api import Domain" else lines[0]


def _block_text(page: str, info: str) -> str:
    """The first block of kind ``info`` in ``page`` (a file the page's commands use)."""
    return "\n".join(next(body for _, i, body in fenced_blocks(ROOT / page) if i == info)) + "\n"


EXAMPLES = examples()


# -- running ---------------------------------------------------------------------------------


def _env(scratch: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
    env["PYTHONUNBUFFERED"] = "1"          # output interleaved as a terminal shows it
    env.pop("DISPLAY", None)
    return env


def _localise(command: str, scratch: Path, port: int) -> str:
    """What a command needs to run here: /tmp/ is the scratch folder's, and the serving
    examples' port 7070 a free one (another run may hold 7070)."""
    return command.replace("/tmp/", f"{scratch}/tmp/").replace(":7070", f":{port}").replace(" 7070", f" {port}")


NORMALISE = [
    (re.compile(r"\b\d+(?:\.\d+)? ?(?:s|ms)\b"), "<time>"),
    (re.compile(r"/dev/pts/\d+"), "<pty>"),
    (re.compile(r"(?:/tmp|/var/tmp)/[^\s'\")]*"), "<tmp>"),
]


def normalise(text: str, scratch: Path) -> list[str]:
    text = text.replace(str(scratch) + "/", "").replace(str(scratch), ".")
    for pattern, repl in NORMALISE:
        text = pattern.sub(repl, text)
    lines = [ln.rstrip() for ln in text.split("\n")]
    while lines and not lines[-1]:
        lines.pop()
    while lines and not lines[0]:
        lines.pop(0)
    return lines


def matches(shown: list[str], got: list[str]) -> bool:
    """``shown`` is ``got``, a ``...`` line standing for any lines (none too)."""
    if not shown:
        return not got
    if shown[0] == "...":
        return any(matches(shown[1:], got[k:]) for k in range(len(got) + 1))
    return bool(got) and shown[0] == got[0] and matches(shown[1:], got[1:])


def run(command: str, scratch: Path, stdin: str = "", timeout: float = 400) -> tuple[int, str]:
    proc = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", command], cwd=scratch, env=_env(scratch),
                          input=stdin, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                          timeout=timeout)
    return proc.returncode, proc.stdout


class Served:
    """A command that serves until stopped: started, read until its up line, stopped on
    SIGINT.  Its output is read on a thread so that it never blocks on a full pipe."""

    def __init__(self, command: str, scratch: Path, ready: str) -> None:
        self.command = command
        self.proc = subprocess.Popen(["bash", "-c", f"exec {command}"], cwd=scratch, env=_env(scratch),
                                     stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, start_new_session=True)
        self.lines: list[str] = []
        self.up = threading.Event()
        self._ready = re.compile(ready)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip("\n"))
            if self._ready.search(line.rstrip("\n")):
                self.up.set()
        self.up.set()

    def wait_up(self, timeout: float = 300) -> None:
        assert self.up.wait(timeout), f"{self.command}: never came up:\n" + "\n".join(self.lines)
        assert self.proc.poll() is None, f"{self.command}: ended (exit {self.proc.returncode}):\n" + \
            "\n".join(self.lines)

    def stop(self, timeout: float = 60) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
        try:
            return self.proc.wait(timeout)
        finally:
            if self.proc.poll() is None:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
            self._reader.join(10)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _tree() -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(ROOT)): (p.stat().st_size, p.stat().st_mtime_ns)
            for top in ("domains", "bench/data") for p in (ROOT / top).rglob("*") if p.is_file()}


@pytest.fixture
def scratch(tmp_path: Path) -> Iterator[Path]:
    """A folder with what the examples use of the repository: domains/ and bench/data/.  After
    the example, the tree's copies are as they were, and nothing the example made in its
    folder is in the tree either."""
    shutil.copytree(ROOT / "domains", tmp_path / "domains")
    shutil.copytree(ROOT / "bench" / "data", tmp_path / "bench" / "data")
    (tmp_path / "tmp").mkdir()
    before, names = _tree(), set(os.listdir(ROOT))
    yield tmp_path
    assert _tree() == before, "an example wrote into the tree's domains/ or bench/data/"
    made = set(os.listdir(tmp_path)) - {"domains", "bench", "tmp"}
    assert not (made & (set(os.listdir(ROOT)) - names)), f"an example wrote {sorted(made)} into the tree"


def _params() -> list:
    params = []
    for block in EXAMPLES:
        marks = []
        if any(c.text in SLOW for c in block.commands):
            marks.append(pytest.mark.slow)
        if all(c.text in NOT_RUN for c in block.commands):
            continue
        params.append(pytest.param(block, id=block.id, marks=marks))
    return params


@pytest.mark.parametrize("block", _params())
def test_the_example_runs_as_printed(block: Block, scratch: Path) -> None:
    port = _free_port()
    setup = _setup_for(block.first)
    server = None
    broken: list[str] = []       # what failed of KNOWN_BROKEN
    try:
        if setup is not None:
            for path, text in setup.files.items():
                (scratch / path).write_text(text)
            for command in setup.before:
                code, out = run(command, scratch)
                assert code == 0, f"{block.id}: the setup `{command}` failed:\n{out}"
            if setup.server:
                server = Served(_localise(setup.server, scratch, port), scratch, setup.server_ready)
                server.wait_up()
        if block.kind == "python":
            (scratch / "example.py").write_text(block.source)
            code, out = run(f"{sys.executable} example.py", scratch)
            assert code == 0, f"{block.id}: the example exits {code}:\n{out}"
            return
        for command in block.commands:
            if command.text in NOT_RUN:
                continue
            where = f"{block.page}:{command.line}: `{command.text}`"
            text = _localise(command.text, scratch, port)
            if command.text in SERVES:
                served = Served(text, scratch, SERVES[command.text])
                served.wait_up()
                code = served.stop()
                assert _stopped_as_documented(command.text, code), \
                    f"{where}: exit {code} on SIGINT:\n" + "\n".join(served.lines)
                continue
            code, out = run(text, scratch, command.stdin)
            expected = EXIT.get(command.text, 0)
            shown = None if command.output is None else normalise("\n".join(command.output), scratch)
            ok = code == expected and (shown is None or matches(shown, normalise(out, scratch)))
            if command.text in KNOWN_BROKEN:
                if not ok:
                    broken.append(f"{where}: {KNOWN_BROKEN[command.text]} (exit {code})")
                    continue
                pytest.fail(f"{where} runs now: drop it from KNOWN_BROKEN")
            assert code == expected, f"{where}: exit {code}, not {expected}:\n{out}"
            if shown is not None:
                got = normalise(out, scratch)
                assert matches(shown, got), f"{where}: prints\n" + "\n".join(got) + \
                    "\n\nwhere the page shows\n" + "\n".join(shown)
        if broken:
            pytest.xfail("; ".join(broken))
    finally:
        if server is not None:
            code = server.stop()
            assert _stopped_as_documented(server.command, code), \
                f"{server.command}: exit {code} on SIGINT:\n" + "\n".join(server.lines)


# -- the lists stay honest -------------------------------------------------------------------


def _everything_named() -> set[str]:
    return {c.text for b in EXAMPLES for c in b.commands}


@pytest.mark.parametrize("table", ["NOT_RUN", "KNOWN_BROKEN", "EXIT", "SERVES", "SLOW"])
def test_every_listed_example_is_on_a_page(table: str) -> None:
    stale = sorted(set(globals()[table]) - _everything_named())
    assert not stale, f"{table} names what no page shows any more (drop it): {stale}"


def test_the_pages_have_examples_of_every_kind() -> None:
    """The extraction itself: a change of the pages' conventions must not empty it."""
    kinds = {b.kind for b in EXAMPLES}
    assert kinds == {"sh", "transcript", "python"}
    assert sum(len(b.commands) for b in EXAMPLES) >= 40


def test_a_transcript_is_parsed_into_commands_input_and_output() -> None:
    body = ["$ cplus shell", "?- loadf 'x.cp'.", "% loading file x.cp", "?- halt.", "$ echo a  # b", "a"]
    first, second = _transcript(10, body)
    assert (first.text, first.stdin, first.output) == ("cplus shell", "loadf 'x.cp'.\nhalt.\n", ["% loading file x.cp"])
    assert (second.text, second.line, second.output) == ("echo a", 15, ["a"])


def test_the_comparison_allows_only_what_must_vary(tmp_path: Path) -> None:
    got = normalise(f"% done (0.09 s)\n{tmp_path}/out/x.png\n/dev/pts/7 at /tmp/cplus-1/tty\n", tmp_path)
    assert got == ["% done (<time>)", "out/x.png", "<pty> at <tmp>"]
    assert matches(["a", "...", "d"], ["a", "b", "c", "d"]) and matches(["a", "...", "b"], ["a", "b"])
    assert not matches(["a", "b"], ["a", "b", "c"]) and not matches(["a", "...", "d"], ["a", "b"])
    assert normalise("cost = 6 (optimal over maxstep 0..10)", tmp_path) == ["cost = 6 (optimal over maxstep 0..10)"]


def test_a_file_shown_beside_its_link_is_that_file() -> None:
    """A block right after a paragraph ending with a link to a file in the repository, and a
    colon, shows that file as it is."""
    checked = 0
    for page in PAGES:
        text = page.read_text(encoding="utf-8").split("\n")
        for line, info, body in fenced_blocks(page):
            before = next((t for t in reversed(text[:line - 1]) if t.strip()), "")
            m = re.search(r"\]\(([^)#]+)\):$", before)
            if not m or info not in ("", "text"):
                continue
            target = (page.parent / m.group(1)).resolve()
            if target.is_file():
                assert "\n".join(body) + "\n" == target.read_text(encoding="utf-8"), \
                    f"{page.name}:{line} shows {m.group(1)} other than it is"
                checked += 1
    assert checked >= 1


def test_the_show_trap_is_as_the_readme_says(tmp_path: Path) -> None:
    """README, "Your first domain": a `:- show` of patterns drops the ACTIONS: lines; adding
    the actions to the patterns brings them back."""
    readme = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    assert "say `:- show at; dirty(R).`, displays only what its patterns match, actions included, so the " \
           "`ACTIONS:` lines disappear; add `go(R); suck; cleaners` to the patterns to keep them" in readme
    vacuum = (ROOT / "domains/examples/vacuum.cp").read_text()
    outputs = []
    for show in (":- show at; dirty(R).", ":- show at; dirty(R); go(R); suck; cleaners."):
        (tmp_path / "v.cp").write_text(vacuum + show + "\n")
        code, out = run("cplus plan v.cp --minimize cost --over-lengths", tmp_path)
        assert code == 0, out
        outputs.append(out)
    assert "ACTIONS:" not in outputs[0] and "4:  at=study" in outputs[0] and "cost=" not in outputs[0]
    assert outputs[1].count("ACTIONS:") == 4
