"""``cplus replay LOG --animate FILE``: an online run's log (``cplus online --log``, ``cplus serve
--log``; schema ``cplus.online/1``) replayed as an animation, one frame per cycle.

A run of the payload arms (its start record names the scene, or ``--scene``) shows the arms and
the payload where each cycle's state puts them, with the hands' trails and where it re-planned
or failed; any other run shows its state's fluents over the cycles. Beside it, each cycle's
time, actions, events, sensed values, re-plan and failure, and at the end how the run ended.

The log is checked before anything is drawn: a missing file, a file that is not such a log, a
line that is not JSON, or a last line cut off (a run killed while writing) is one line on stderr
and exit code 2.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any

from cplus.cli.animation_options import FrameProgress, add_animation_options, animation_check
from cplus.cli.common import EXIT_INPUT, EXIT_OK, CliError, OneLineArgumentParser
from cplus.cli.paths import Input, Output, check_paths
from cplus.files import output_path

__all__ = ["build_parser", "main", "read_log", "frames_of"]

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
    p.add_argument("--quiet", "-q", action="store_true", help="no progress on stderr")
    return p


def _fail(where: str, message: str) -> CliError:
    return CliError(f"{PROG}: error: {where}: {message}")


def read_log(path: str) -> tuple[dict[str, Any], list[dict[str, Any]], dict[str, Any] | None]:
    """The start record, the cycle records and the end record (None: the run did not end).

    Raises:
        CliError: one line naming the file, the line and what is wrong.
    """
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
    lines = text.split("\n")
    complete = text.endswith("\n")
    if complete:
        lines.pop()
    records = []
    for n, line in enumerate(lines, 1):
        try:
            record = json.loads(line)
        except json.JSONDecodeError as exc:
            if n == len(lines) and not complete and n > 1:
                raise _fail(f"{path}:{n}", "the last line is cut off (the run was stopped while writing it)") from None
            raise _fail(f"{path}:{n}", f"not JSON: {exc.msg} at column {exc.colno}"
                        + (f" (not a {ONLINE_FORMAT} log)" if n == 1 else "")) from None
        except RecursionError:
            raise _fail(f"{path}:{n}", "JSON nested too deeply") from None
        if not isinstance(record, dict) or not isinstance(record.get("record"), str):
            raise _fail(f"{path}:{n}", "a record is a JSON object with a \"record\" field")
        records.append((n, record))
    if not records or records[0][1].get("record") != "start" or records[0][1].get("format") != ONLINE_FORMAT:
        raise _fail(f"{path}:1", f"not a {ONLINE_FORMAT} log (its first line is not the run's start record)")
    cycles, end = [], None
    for n, record in records[1:]:
        kind = record["record"]
        if end is not None:
            raise _fail(f"{path}:{n}", "a record after the end record")
        if kind == "cycle":
            _check_cycle(record, f"{path}:{n}")
            cycles.append(record)
        elif kind == "end":
            end = record
        else:
            raise _fail(f"{path}:{n}", f"unknown record {kind!r} (expected cycle or end)")
    if not cycles:
        raise _fail(path, "the log has no cycle to replay")
    return records[0][1], cycles, end


def _check_cycle(record: dict[str, Any], where: str) -> None:
    if not isinstance(record.get("cycle"), int) or isinstance(record.get("cycle"), bool):
        raise _fail(where, "a cycle record needs \"cycle\" (a whole number)")
    t = record.get("time")
    if not isinstance(t, (int, float)) or isinstance(t, bool):
        raise _fail(where, "a cycle record needs \"time\" (seconds)")
    if record.get("state") is not None and not isinstance(record["state"], dict):
        raise _fail(where, "\"state\" must be an object (fluent: value) or null")
    for key in ("events", "inferred", "executed", "notes", "goals"):
        if not isinstance(record.get(key, []), list):
            raise _fail(where, f"\"{key}\" must be a list")
    for key in ("sensed", "replanned"):
        if record.get(key) is not None and not isinstance(record[key], dict):
            raise _fail(where, f"\"{key}\" must be an object or null")


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
    out: list[list] = []
    for item in items:
        if out and out[-1][0] == item:
            out[-1][1] += 1
        else:
            out.append([item, 1])
    return ", ".join(f"{a} x{n}" if n > 1 else a for a, n in out)


def frames_of(cycles: list[dict[str, Any]], end: dict[str, Any] | None, scene=None) -> list:
    """One :class:`trajectory.CycleFrame` per cycle, and one for the end record."""
    import trajectory
    frames = []
    state: dict[str, Any] = {}
    for record in cycles:
        failed = record.get("state") is None or bool(record.get("failure"))
        if record.get("state") is not None:
            state = record["state"]
        replan = record.get("replanned")
        frames.append(trajectory.CycleFrame(
            record["cycle"], float(record["time"]), {k: _text(v) for k, v in state.items()},
            _positions(state, scene), tuple(_trace(record)),
            replanned=isinstance(replan, dict) and replan.get("reason") != "start", failed=failed))
    if end is not None:
        last = frames[-1]
        final: dict[str, Any] = end["state"] if isinstance(end.get("state"), dict) else state
        seconds = _number(end.get("seconds"))
        status = str(end.get("status", "?"))
        lines = [f"the run ended: {status}", str(end.get("message", ""))]
        if isinstance(end.get("replans"), int):
            n = end["replans"]
            lines.append(f"{end.get('cycles', len(cycles))} cycles, {n} re-plan{'' if n == 1 else 's'}")
        frames.append(trajectory.CycleFrame(
            last.cycle, max(last.time_s, seconds if seconds is not None else last.time_s),
            {k: _text(v) for k, v in final.items()}, _positions(final, scene), tuple(lines),
            failed=status != "goal_reached", ended=True))
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
        start, cycles, end = read_log(args.log)
        scene = _scene(args, start)
        named = start.get("scene") if isinstance(start.get("scene"), str) else None
        check_paths(PROG, [Input(args.scene or named, "the scene")], [Output("--animate", args.animate)])
    except CliError as exc:
        print(exc, file=err)
        return EXIT_INPUT
    except trajectory.SceneError as exc:
        print(f"{PROG}: error: {exc}", file=err)
        return EXIT_INPUT
    frames = frames_of(cycles, end, scene)
    domain = os.path.basename(str(start.get("domain", args.log)))
    title = f"{domain}: goal '{start.get('goal', '?')}' on {start.get('executor', 'a robot')}"
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
