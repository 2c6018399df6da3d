"""``cplus replay LOG --animate FILE``: an online run's log (``cplus online --log``, ``cplus serve
--log``; schema ``cplus.online/1``) replayed as an animation, one frame per cycle.

A run of the payload arms (its start record names the scene, or ``--scene``) shows the arms and
the payload where each cycle's state puts them, with the hands' trails and where it re-planned
or failed; any other run shows its state's fluents over the cycles. Beside it, each cycle's
time, actions, events, sensed values, re-plan and failure, and at the end how the run ended.

A log continued after a restart holds several runs, each from its start record to its end
record (a run without one crashed or was killed, and is drawn so); the last is replayed unless
``--run N`` picks another. A cycle is one turn of the loop: the state observed, the plan kept
or made again, a step sent (the payload arms: what is left of the plan); the last cycle of a
run finds the goal (or the reason to stop) and sends nothing, so a run that reached its goal at
cycle 8 ran 8 cycles, as ``cplus online`` says, and is replayed as 9 cycle frames and its end.

The log is checked before anything is drawn: a missing file, a file that is not such a log, a
line that is not JSON (but a line cut off at the end of a run, which was killed while writing
it), cycles out of order or at a time that is not a finite number of seconds going forward, or
a record out of place is one line on stderr naming the file and the line, and exit code 2.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
from typing import Any, NamedTuple

from cplus.cli.animation_options import FrameProgress, add_animation_options, animation_check
from cplus.cli.common import EXIT_INPUT, EXIT_OK, CliError, OneLineArgumentParser, positive_int
from cplus.cli.paths import Input, Output, check_paths
from cplus.files import output_path

__all__ = ["build_parser", "main", "read_log", "read_runs", "pick_run", "Run", "frames_of", "cycles_ran"]

PROG = "cplus replay"
#: The format of the logs replayed (:data:`cplus.robot.online.loop.ONLINE_FORMAT`, which a test holds equal).
ONLINE_FORMAT = "cplus.online/1"
MAX_LOG = 512 * 1024 * 1024
"""The largest log read (bytes): a day of cycles; anything larger is a mistake (a device)."""


def build_parser() -> OneLineArgumentParser:
    p = OneLineArgumentParser(prog=PROG, description="Replay the JSON-lines log of `cplus online` or `cplus serve` "
                              "as an animation, one frame per cycle.")
    p.add_argument("log", help="the run's log (cplus.online/1 JSON lines, from --log)")
    add_animation_options(p, "where each cycle's state puts them (any other run: its fluents over the cycles)")
    p.add_argument("--scene", metavar="FILE", help="the scene of a payload-arms run (default: the one its log names)")
    p.add_argument("--run", type=positive_int, metavar="N",
                   help="the run to replay when the log holds several (a log continued after a restart): 1 is the "
                        "first (default: the last)")
    p.add_argument("--quiet", "-q", action="store_true", help="no progress on stderr")
    return p


def _fail(where: str, message: str) -> CliError:
    return CliError(f"{PROG}: error: {where}: {message}")


class Run(NamedTuple):
    """One run of a log: its number (1-based), the line of its start record, the records, and
    ``cut``: the line cut off at its end (a run killed while writing it), if any."""

    number: int
    line: int
    start: dict[str, Any]
    cycles: list[dict[str, Any]]
    end: dict[str, Any] | None
    cut: int | None = None


_START = re.compile(r'\{\s*"record"\s*:\s*"start"')
"""How a start record's line begins (the logs are written compact, ``{"record":"start",...}``;
spaces allowed, for a log written by other tools)."""


def _read_text(path: str) -> str:
    if not os.path.isfile(path):
        raise _fail(path, "not a regular file" if os.path.exists(path) else "no such file")
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_LOG + 1)
    except OSError as exc:
        raise _fail(path, f"cannot read: {exc.strerror}") from None
    if len(data) > MAX_LOG:
        raise _fail(path, f"a log has at most {MAX_LOG} bytes")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise _fail(path, f"not a {ONLINE_FORMAT} log (not UTF-8 text)") from None
    if not text.strip():
        raise _fail(path, f"the file is empty (not a {ONLINE_FORMAT} log)")
    return text


def _records(path: str, text: str) -> list[tuple[int, dict[str, Any] | None]]:
    """``(line, record)`` for every line; ``None`` for a line cut off by a run killed while
    writing it: the file's last line without its line end, or a line whose JSON stops where
    a restarted run's start record begins (the start record is then read on its own)."""
    lines = text.split("\n")
    complete = text.endswith("\n")
    if complete:
        lines.pop()
    out: list[tuple[int, dict[str, Any] | None]] = []
    for n, line in enumerate(lines, 1):
        try:
            record = json.loads(line)
        except json.JSONDecodeError as exc:
            found = _START.search(line, 1)
            restart = found.start() if found else -1
            if n > 1 and ((n == len(lines) and not complete) or (n < len(lines) and _starts_run(lines[n]))):
                out.append((n, None))
                continue
            if restart > 0:
                out.append((n, None))
                line = line[restart:]
                try:
                    record = json.loads(line)
                except json.JSONDecodeError as inner:
                    raise _fail(f"{path}:{n}", f"not JSON: {inner.msg}") from None
            else:
                raise _fail(f"{path}:{n}", f"not JSON: {exc.msg} at column {exc.colno}"
                            + (f" (not a {ONLINE_FORMAT} log)" if n == 1 else "")) from None
        except RecursionError:
            raise _fail(f"{path}:{n}", "JSON nested too deeply") from None
        if not isinstance(record, dict) or not isinstance(record.get("record"), str):
            raise _fail(f"{path}:{n}", "a record is a JSON object with a \"record\" field")
        out.append((n, record))
    return out


def _starts_run(line: str) -> bool:
    """Whether a line is a run's start record (a line cut off before it ended a crashed run)."""
    if not _START.match(line):
        return False
    try:
        return isinstance(json.loads(line), dict)
    except (json.JSONDecodeError, RecursionError):
        return False


def read_runs(path: str) -> list[Run]:
    """Every run of a log, in order: a log continued after a restart holds several, each from
    its start record to its end record (a run without one crashed or was killed).

    Raises:
        CliError: one line naming the file, the line and what is wrong.
    """
    records = _records(path, _read_text(path))
    first = records[0][1]
    if first is None or first.get("record") != "start" or first.get("format") != ONLINE_FORMAT:
        raise _fail(f"{path}:1", f"not a {ONLINE_FORMAT} log (its first line is not the run's start record)")
    runs: list[Run] = []
    goals: list[dict[str, Any]] = []      # a server's goal records (cplus.serve/3), shown with the next cycle
    for n, record in records:
        where = f"{path}:{n}"
        current = runs[-1] if runs else None
        if current is not None and current.cut is not None:
            if record is None or record["record"] != "start":
                raise _fail(f"{path}:{current.cut}", "not JSON: a line cut off, and the run goes on after it")
        if record is None:                    # the run was killed while writing this line
            assert current is not None
            if current.end is not None:
                raise _fail(where, "not JSON: a line cut off after the run's end record")
            runs[-1] = current._replace(cut=n)
            continue
        kind = record["record"]
        if kind == "start":
            if record.get("format") != ONLINE_FORMAT:
                raise _fail(where, f"a start record of another format than {ONLINE_FORMAT}")
            _flush_goals(runs, goals)
            runs.append(Run(len(runs) + 1, n, record, [], None))
            continue
        assert current is not None
        if current.end is not None:
            raise _fail(where, "a record after the end record (a run that follows begins with its start record)")
        if kind == "cycle":
            _check_cycle(record, where, current.cycles[-1] if current.cycles else None)
            if goals:
                record, goals = dict(record, goals=[*record.get("goals", []), *goals]), []
            current.cycles.append(record)
        elif kind == "goal":
            goals.append(record)
        elif kind == "end":
            _check_end(record, where)
            runs[-1] = current._replace(end=record)
        else:
            raise _fail(where, f"unknown record {kind!r} (expected cycle, goal, end, or the start of another run)")
    _flush_goals(runs, goals)
    return runs


def _flush_goals(runs: list[Run], goals: list[dict[str, Any]]) -> None:
    """Goal records after a run's last cycle go with that cycle (a run ended, or was killed, with
    goals still changing)."""
    if goals and runs and runs[-1].cycles:
        last = runs[-1].cycles
        last[-1] = dict(last[-1], goals=[*last[-1].get("goals", []), *goals])
    goals.clear()


def read_log(path: str, run: int | None = None) -> tuple[dict[str, Any], list[dict[str, Any]], dict[str, Any] | None]:
    """The start record, the cycle records and the end record (None: the run did not end) of
    one run of a log: the last unless ``run`` (1-based) picks another.

    Raises:
        CliError: one line naming the file, the line and what is wrong.
    """
    chosen = pick_run(path, read_runs(path), run)
    return chosen.start, chosen.cycles, chosen.end


def pick_run(path: str, runs: list[Run], run: int | None) -> Run:
    """The run to replay (``run``: 1-based; None: the last), with a cycle to replay."""
    if run is not None and not 1 <= run <= len(runs):
        raise CliError(f"{PROG}: error: --run {run}: {path} holds {len(runs)} run{'' if len(runs) == 1 else 's'}")
    chosen = runs[-1] if run is None else runs[run - 1]
    if not chosen.cycles:
        if len(runs) == 1:
            raise _fail(path, "the log has no cycle to replay")
        others = [r.number for r in runs if r.cycles]
        hint = f" (runs with cycles: {', '.join(map(str, others))}; pick one with --run N)" if others else ""
        raise _fail(f"{path}:{chosen.line}", f"run {chosen.number} of {len(runs)} has no cycle to replay{hint}")
    return chosen


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check_cycle(record: dict[str, Any], where: str, previous: dict[str, Any] | None) -> None:
    if not isinstance(record.get("cycle"), int) or isinstance(record.get("cycle"), bool):
        raise _fail(where, "a cycle record needs \"cycle\" (a whole number)")
    t = record.get("time")
    if not isinstance(t, (int, float)) or isinstance(t, bool):
        raise _fail(where, "a cycle record needs \"time\" (seconds)")
    if not math.isfinite(t) or t < 0:
        raise _fail(where, f"\"time\" must be a finite number of seconds from the run's start, not {t}")
    if previous is not None:
        if record["cycle"] <= previous["cycle"]:
            raise _fail(where, f"cycle {record['cycle']} after cycle {previous['cycle']}: a run's cycles are in "
                               "increasing order")
        if t < previous["time"]:
            raise _fail(where, f"cycle {record['cycle']} at {t} s, before the cycle ahead of it "
                               f"({previous['time']} s)")
    if record.get("state") is not None and not isinstance(record["state"], dict):
        raise _fail(where, "\"state\" must be an object (fluent: value) or null")
    for key in ("events", "inferred", "executed", "notes", "goals"):
        if not isinstance(record.get(key, []), list):
            raise _fail(where, f"\"{key}\" must be a list")
    for key in ("sensed", "replanned"):
        if record.get(key) is not None and not isinstance(record[key], dict):
            raise _fail(where, f"\"{key}\" must be an object or null")


def _check_end(record: dict[str, Any], where: str) -> None:
    seconds = record.get("seconds")
    if seconds is not None and not (_finite(seconds) and seconds >= 0):
        raise _fail(where, f"\"seconds\" must be a finite number of seconds, not {seconds}")
    for key in ("cycles", "replans"):
        value = record.get(key)
        if value is not None and (not isinstance(value, int) or isinstance(value, bool) or value < 0):
            raise _fail(where, f"\"{key}\" must be a whole number")
    if record.get("state") is not None and not isinstance(record["state"], dict):
        raise _fail(where, "\"state\" must be an object (fluent: value) or null")


def _text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return "none" if value is None else str(value)


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None


def _positions(state: dict[str, Any], scene) -> dict[str, tuple[float, float]]:
    """Where the scene's bindings put each robot's hand and each payload end in ``state``."""
    if scene is None:
        return {}
    out = {}
    bodies = [(r.name, r.x.fluent, r.y.fluent) for r in scene.robots]
    bodies += [(e.name, e.x.fluent, e.y.fluent) for e in scene.payload.ends]
    for name, fx, fy in bodies:
        x, y = _number(state.get(fx)), _number(state.get(fy))
        if x is not None and y is not None:
            out[name] = (x, y)
    return out


def _trace(record: dict[str, Any]) -> list[str]:
    """What happened at a cycle, in the order the loop did it."""
    lines = []
    if record.get("events"):
        lines.append("events: " + ", ".join(map(str, record["events"])))
    if record.get("inferred"):
        lines.append("inferred: " + ", ".join(map(str, record["inferred"])))
    if record.get("sensed"):
        lines.append("sensed: " + ", ".join(f"{k}={_text(v)}" for k, v in record["sensed"].items()))
    replan = record.get("replanned")
    plan = record.get("plan")
    steps = len(plan) if isinstance(plan, list) else None
    if replan:
        reason = str(replan.get("reason", "?"))
        fluents = replan.get("fluents") if isinstance(replan.get("fluents"), dict) else {}
        head = "planned" if reason == "start" else f"RE-PLANNED ({reason})"
        lines.append(head + (f": {steps} steps" if steps is not None else ""))
        for name, change in list(fluents.items())[:6]:
            if isinstance(change, dict):
                lines.append(f"  {name}: predicted {_text(change.get('predicted'))}, "
                             f"observed {_text(change.get('observed'))}")
    elif steps is not None:
        lines.append(f"plan ahead: {steps} steps")
    if record.get("executed"):
        lines.append(f"executed ({len(record['executed'])}): " + _runs(list(map(str, record["executed"]))))
    elif record.get("state") is not None:
        lines.append("executed: nothing (an idle step)")
    if record.get("failure"):
        lines.append(f"FAILURE: {record['failure']}")
    for goal in record.get("goals") or []:       # a server's log: the goals that changed
        if isinstance(goal, dict):
            lines.append(f"goal {goal.get('id', '?')} {goal.get('request', '')}: {goal.get('status', '?')}"
                         + (f" ({goal['reason']})" if goal.get("reason") else ""))
    lines += [f"note: {n}" for n in record.get("notes", [])]
    return lines


def _runs(items: list[str]) -> str:
    """``a, b x3, c``: repeated neighbours counted."""
    return ", ".join(_counted(items))


def _counted(items: list[str]) -> list[str]:
    """``["a", "b x3", "c"]``: repeated neighbours counted."""
    out: list[list] = []
    for item in items:
        if out and out[-1][0] == item:
            out[-1][1] += 1
        else:
            out.append([item, 1])
    return [f"{a} x{n}" if n > 1 else a for a, n in out]


def cycles_ran(cycles: int) -> int:
    """How many cycles of a run acted, as ``cplus online`` counts them: a cycle sends a step (or
    waits), and the last cycle of a run that ended, the one that found the goal or the reason
    to stop, sends nothing; the end record's ``cycles`` counts that one too."""
    return max(cycles - 1, 0)


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def frames_of(cycles: list[dict[str, Any]], end: dict[str, Any] | None, scene=None, *, crashed: bool = False,
              cut: int | None = None) -> list:
    """One :class:`trajectory.CycleFrame` per cycle, and one for the end record; with
    ``crashed`` (a run without an end record) one that says so (``cut``: the line cut off)."""
    import trajectory
    frames = []
    state: dict[str, Any] = {}
    for record in cycles:
        failed = record.get("state") is None or bool(record.get("failure"))
        if record.get("state") is not None:
            state = record["state"]
        replan = record.get("replanned")
        executed = list(map(str, record.get("executed") or []))
        frames.append(trajectory.CycleFrame(
            record["cycle"], float(record["time"]), {k: _text(v) for k, v in state.items()},
            _positions(state, scene), tuple(_trace(record)),
            replanned=isinstance(replan, dict) and replan.get("reason") != "start", failed=failed,
            actions=tuple(_counted(executed))))
    last = frames[-1]
    if end is not None:
        final: dict[str, Any] = end["state"] if isinstance(end.get("state"), dict) else state
        seconds = _number(end.get("seconds"))
        status = str(end.get("status", "?"))
        lines = [f"the run ended: {status}", str(end.get("message", ""))]
        if isinstance(end.get("replans"), int):
            n = end["replans"]
            ran = cycles_ran(end["cycles"] if isinstance(end.get("cycles"), int) else len(cycles))
            lines.append(f"{_plural(ran, 'cycle')} ran, {_plural(n, 'replan')}")
        frames.append(trajectory.CycleFrame(
            last.cycle, max(last.time_s, seconds if seconds is not None else last.time_s),
            {k: _text(v) for k, v in final.items()}, _positions(final, scene), tuple(lines),
            failed=status != "goal_reached", ended=True))
    elif crashed:
        lines = ["the run has no end record: it crashed or was killed",
                 f"after cycle {last.cycle} ({_plural(len(cycles), 'cycle record')} in the log)"]
        if cut is not None:
            lines.append(f"its last line ({cut}) is cut off: it was stopped while writing it")
        frames.append(trajectory.CycleFrame(last.cycle, last.time_s, {k: _text(v) for k, v in state.items()},
                                            _positions(state, scene), tuple(lines), failed=True, ended=True))
    return frames


def _scene(args: argparse.Namespace, start: dict[str, Any]):
    import trajectory
    path = args.scene or (start.get("scene") if isinstance(start.get("scene"), str) else None)
    if path is None:
        return None
    if not os.path.isfile(path):
        hint = "" if args.scene else ": give --scene FILE"
        raise _fail(path, ("no such file" if not os.path.exists(path) else "not a regular file")
                    + (f" (the scene the log names{hint})" if not args.scene else ""))
    return trajectory.load_scene(path)


def main(args: argparse.Namespace) -> int:
    """``cplus replay``; returns the exit code."""
    import trajectory
    err = sys.stderr
    try:
        if not args.animate:
            raise CliError(f"{PROG}: error: nothing to do: give --animate FILE (.gif, or .mp4 with ffmpeg)")
        problem = animation_check(args.animate, "--animate", PROG)
        if problem is not None:
            raise CliError(problem)
        check_paths(PROG, [Input(args.log, "the log"), Input(args.scene, "the scene")],
                    [Output("--animate", args.animate)])
        runs = read_runs(args.log)
        run = pick_run(args.log, runs, args.run)
        scene = _scene(args, run.start)
        named = run.start.get("scene") if isinstance(run.start.get("scene"), str) else None
        check_paths(PROG, [Input(args.scene or named, "the scene")], [Output("--animate", args.animate)])
    except CliError as exc:
        print(exc, file=err)
        return EXIT_INPUT
    except trajectory.SceneError as exc:
        print(f"{PROG}: error: {exc}", file=err)
        return EXIT_INPUT
    frames = frames_of(run.cycles, run.end, scene, crashed=run.end is None, cut=run.cut)
    start = run.start
    domain = os.path.basename(str(start.get("domain", args.log)))
    title = f"{domain}: goal '{start.get('goal', '?')}' on {start.get('executor', 'a robot')}"
    if len(runs) > 1:
        title += f" (run {run.number} of {len(runs)})"
    try:
        with output_path(args.animate) as tmp:
            trajectory.animate_cycles(frames, tmp, scene=scene, title=title, max_frames=args.frames,
                                      dpi=args.dpi, on_progress=FrameProgress(PROG, args.animate, err, args.quiet))
    except trajectory.TrajectoryError as exc:
        print(f"{PROG}: error: {exc}", file=err)
        return EXIT_INPUT
    except OSError as exc:
        print(f"{PROG}: error: cannot write {args.animate}: {exc.strerror or exc}", file=err)
        return EXIT_INPUT
    if not args.quiet:
        print(f"{PROG}: wrote {args.animate} ({len(frames)} frames)", file=err)
    return EXIT_OK
