"""The binding file (``robot.toml``, ``cplus.robot/1``): which robot does what in a C+ domain.

C+ does not say which actions the robot performs and which happen to it, nor which fluents a
sensor reads. The binding file beside a domain says so, for the online loop:

* ``[bricks.NAME]``: a brick (``--brick NAME=PORT`` opens it), the sensors on its input ports
  (``sensors = { S1 = "touch", S3 = "light" }``), and the emulated world it lives in when no
  port is given (``world = "world.toml"``, relative to the binding file);
* ``[actions.C]``: the action constant ``C`` (every ground instance of that name, or one
  instance written out, ``[actions."goto(2)"]``) is the robot's. It runs ``behaviour`` N on
  brick ``brick`` with ``args``: integers, ``"$1"``.. for the action's own arguments, or
  ``"$name"`` for the value of one of its attributes. ``stop = "halted"``: the action may be
  stopped part-way (``cplus serve --preempt stop``), and then the event ``halted`` (bound with
  source ``"stop"``) happened with it, so that the domain says where that leaves the robot;
* ``[events.C]``: ``C`` is an event, with its ``source``. ``"brick"``: the brick program
  reports it (``event = "button"``), its arguments becoming the constant's. ``"sensor"``:
  the PC reads a sensor ``port`` of a ``brick`` after every step and the event happens when
  the reading crosses ``below`` or ``above``. ``"input"``: a line of ``--events`` (or a
  request channel). ``"inferred"``: nothing reports it, and the state estimate decides
  whether it happened. ``"stop"``: the executor reports it when it stopped an action part-way
  (the action's ``stop``);
* ``[sensed.F]``: the fluent ``F`` is read after each step, either from a ``value`` that the
  brick's behaviours return (``value = "landmark"``) or from a sensor ``port``. The reading
  maps to a value of ``F`` through ``thresholds``/``values`` (``n`` increasing thresholds,
  ``n+1`` values: the first value below the first threshold), a ``map`` table (reading ->
  value), or as it is (an integer of ``F``'s domain; for a Boolean fluent, non-zero is
  true). Readings listed in ``ignore`` say nothing.

Every problem is a :class:`BindingError` located in the file (``robot.toml:12:1: error:
...``), found before anything moves. That includes a field of the wrong type, a binding to a
constant the domain does not have, an action with no binding (located at its declaration in
the domain), a sensor on a motor port, and a value outside a fluent's domain. The schema is
described in ``docs/online.md``.
"""
from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cplus.errors import CPlusError, Location, Source
from cplus.robot.online.estimation import Act, Roles, user_actions
from cplus.signature import GroundConst, render_value
from nxt_link.programs.behaviour_protocol import MAX_ARGS, Event, Sense
from trajectory.toml_locations import (
    KeyPath,
    KeyPathReader,
    kind_of,
    locate_keys,
    nearest_location,
    parse_toml,
    toml_error,
)

__all__ = ["ROBOT_FORMAT", "SENSOR_PORTS", "MOTOR_PORTS", "SENSOR_TYPES", "EVENT_SOURCES", "BindingError",
           "BrickSpec", "ActionBinding", "EventBinding", "SensedBinding", "RobotBinding", "load_binding",
           "parse_binding", "binding_beside"]

ROBOT_FORMAT = "cplus.robot/1"
SENSOR_PORTS = ("S1", "S2", "S3", "S4")
MOTOR_PORTS = ("A", "B", "C")
SENSOR_TYPES = ("touch", "light", "light_ambient", "sound")
EVENT_SOURCES = ("brick", "sensor", "input", "inferred", "stop")
_INT32 = (-(2 ** 31), 2 ** 31 - 1)
INT16 = (-(2 ** 15), 2 ** 15 - 1)
"""A behaviour's arguments travel as int16 (the ACT message): checked at load, literal or not."""

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def binding_beside(domain_path: str) -> str | None:
    """The ``robot.toml`` beside a domain file, if there is one."""
    beside = Path(domain_path).resolve().parent / "robot.toml"
    return str(beside) if beside.is_file() else None


class BindingError(CPlusError):
    """A binding file that is malformed or does not fit its domain."""


@dataclass(frozen=True)
class BrickSpec:
    """A brick: its name, the sensor on each used input port, its emulated world (a file
    that is checked only when the brick is emulated; ``world_location`` is where it is named)."""

    name: str
    sensors: Mapping[str, str]
    world: Path | None
    location: Location
    world_location: Location | None = None


@dataclass(frozen=True)
class ActionBinding:
    """A ground action of the robot: a behaviour of a brick, with argument templates."""

    gc: GroundConst
    brick: str
    behaviour: int
    args: tuple[int | str, ...]
    location: Location
    stop: GroundConst | None = None    # the event that says it was stopped part-way (None: it finishes)

    def call_args(self, act: Act) -> tuple[int, ...]:
        """The behaviour's arguments for one occurrence of the action."""
        out = []
        for a in self.args:
            if isinstance(a, int):
                out.append(a)
            elif a[1:].isascii() and a[1:].isdigit():
                out.append(self.gc.args[int(a[1:]) - 1])
            else:
                value = act.attribute(a[1:])
                if not isinstance(value, int):
                    raise BindingError(f"{act.text}: attribute {a[1:]} is {value!r}, not an integer", self.location)
                out.append(value)
        return tuple(out)


@dataclass(frozen=True)
class EventBinding:
    """An event and where it comes from (``source``: brick, sensor, input, inferred or stop)."""

    gc: GroundConst
    source: str
    location: Location
    brick: str | None = None
    event: str | None = None          # source "brick": the name the program reports
    port: str | None = None           # source "sensor"
    below: int | None = None
    above: int | None = None

    def crossed(self, before: int | None, now: int) -> bool:
        """A sensor event: did the reading cross its threshold since ``before``?"""
        if self.below is not None:
            return now < self.below and (before is None or before >= self.below)
        assert self.above is not None
        return now > self.above and (before is None or before <= self.above)


@dataclass(frozen=True)
class SensedBinding:
    """A sensed fluent: where its reading comes from and how it maps to a value."""

    gc: GroundConst
    brick: str
    location: Location
    value: str | None = None          # a sensing value of the brick's behaviours
    port: str | None = None           # or a sensor port the PC reads
    thresholds: tuple[int, ...] = ()
    values: tuple[object, ...] = ()
    table: Mapping[int, object] = field(default_factory=dict)
    ignore: frozenset[int] = frozenset()

    def map(self, reading: int) -> object | None:
        """The fluent's value for a reading; None when the reading says nothing. A reading
        with no value is returned as it is (the estimate then names it as unexplained)."""
        if reading in self.ignore:
            return None
        if self.thresholds:
            return self.values[sum(1 for t in self.thresholds if reading >= t)]
        if self.table:
            return self.table.get(reading, reading)
        if self.gc.boolean:
            return "true" if reading else "false"
        return reading


@dataclass(frozen=True)
class RobotBinding:
    """A validated ``robot.toml`` for one domain."""

    path: str
    bricks: Mapping[str, BrickSpec]
    actions: Mapping[GroundConst, ActionBinding]
    events: Mapping[GroundConst, EventBinding]
    sensed: Mapping[GroundConst, SensedBinding]

    def roles(self) -> Roles:
        observed = frozenset(gc for gc, e in self.events.items() if e.source != "inferred")
        inferred = frozenset(gc for gc, e in self.events.items() if e.source == "inferred")
        return Roles(frozenset(self.actions), observed, inferred)

    def input_events(self, simulated: bool = False) -> list[str]:
        """The events a line of ``--events`` may name: those from source ``input``; on a
        simulated robot (which has no buttons or sensors) also those from bricks and sensors."""
        sources = ("input", "brick", "sensor") if simulated else ("input",)
        return sorted(gc.text for gc, e in self.events.items() if e.source in sources)

    def brick_event(self, brick: str, name: str, args: Sequence[int]) -> GroundConst | None:
        """The ground event a brick's report stands for (None if no binding matches)."""
        for gc, e in self.events.items():
            if e.source == "brick" and e.brick == brick and e.event == name \
                    and tuple(args[:gc.decl.arity]) == tuple(gc.args):
                return gc
        return None

    def sensed_after(self, action: GroundConst) -> list[str]:
        """Texts of the fluents sensed when ``action`` runs: those its brick reports (a
        simulated robot uses this)."""
        brick = self.actions[action].brick if action in self.actions else None
        return [gc.text for gc, s in self.sensed.items() if s.brick == brick or s.port is not None]


def load_binding(path: str, domain) -> RobotBinding:
    """Read and validate a binding file against a domain (:class:`cplus.api.Domain`)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise BindingError(f"cannot read binding file {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise BindingError(f"binding file {path} is not UTF-8 text: {exc.reason}") from None
    return parse_binding(text, str(p), domain)


def parse_binding(text: str, path: str, domain) -> RobotBinding:
    """Validate the text of a binding file against a domain. Raises :class:`BindingError`."""
    source = Source(path, text)
    try:
        data = parse_toml(text)
    except tomllib.TOMLDecodeError as exc:
        message, line, col = toml_error(exc)
        raise BindingError(message, Location.of_token(source, line, col)) from None
    return _Reader(source, data, locate_keys(text), domain).binding()


class _Reader(KeyPathReader):
    """Reads the parsed TOML with type checks; every complaint names its position."""

    def __init__(self, source: Source, data: dict[str, Any], locations: dict[KeyPath, tuple[int, int]], domain):
        super().__init__(data, locations)
        self.source = source
        self.domain = domain
        sig = domain.program.signature
        self.ground = [gc for gc in sig.ground if not gc.decl.hidden]
        self.actions = user_actions(domain)

    # -- helpers ---------------------------------------------------------------------------
    def loc(self, path: KeyPath) -> Location:
        return Location.of_token(self.source, *nearest_location(self.locations, path))

    def fail(self, path: KeyPath, message: str) -> BindingError:
        return BindingError(message, self.loc(path))

    @staticmethod
    def show(path: KeyPath) -> str:
        out = ""
        for part in path:
            if isinstance(part, int):
                out += f"[{part}]"
            else:
                text = part if _NAME.match(part) else f'"{part}"'
                out += f".{text}" if out else text
        return out or "the top level"

    def table(self, path: KeyPath, allowed: Sequence[str] | None = None, required: bool = True) -> dict[str, Any]:
        if not required and not self.has(path):
            return {}
        value = self.require(path)
        if not isinstance(value, dict):
            raise self.fail(path, f"{self.show(path)} must be a table, not {kind_of(value)}")
        if allowed is not None:
            for key in value:
                if key not in allowed:
                    raise self.fail(path + (key,), f"unknown field '{key}' in {self.show(path)}; expected one of: "
                                    f"{', '.join(allowed)}")
        return value

    def string(self, path: KeyPath, choices: Sequence[str] | None = None) -> str:
        value = self.require(path)
        if not isinstance(value, str):
            raise self.fail(path, f"{self.show(path)} must be a string, not {kind_of(value)}")
        if choices is not None and value not in choices:
            raise self.fail(path, f"{self.show(path)} = {value!r}: expected one of {', '.join(choices)}")
        return value

    def integer(self, path: KeyPath, lo: int = _INT32[0], hi: int = _INT32[1]) -> int:
        value = self.require(path)
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(path, f"{self.show(path)} must be an integer, not {kind_of(value)}")
        if not lo <= value <= hi:
            raise self.fail(path, f"{self.show(path)} = {value} is outside {lo}..{hi}")
        return value

    def array(self, path: KeyPath) -> list:
        value = self.require(path)
        if not isinstance(value, list):
            raise self.fail(path, f"{self.show(path)} must be an array, not {kind_of(value)}")
        return value

    def reported(self, path: KeyPath, codes: type[Event] | type[Sense]) -> str:
        """A name a brick can report: a brick event or a sensing value, as the behaviour client
        names them (the protocol's code names, ``button``, ``landmark``; a code the protocol
        does not name as ``event 7``, ``sense 9``). Anything else is a typo that would never
        match: a press ignored or a fluent never sensed, found only at the end of a run."""
        name = self.string(path)
        known = [c.name.lower() for c in codes]
        prefix = codes.__name__.lower()
        word, _, number = name.partition(" ")
        if name in known or (word == prefix and number and len(number) <= 3 and all(c in "0123456789" for c in number)
                             and int(number) <= 255 and int(number) not in {c.value for c in codes}):
            return name
        raise self.fail(path, f"{self.show(path)} = {name[:40]!r}: a brick reports {', '.join(known)} (or "
                        f"'{prefix} N' for another code N of its program)")

    def brick_ref(self, path: KeyPath, bricks: Mapping[str, BrickSpec]) -> str:
        name = self.string(path)
        if name not in bricks:
            known = ", ".join(bricks) or "none"
            raise self.fail(path, f"unknown brick '{name}' (the [bricks] of this file: {known})")
        return name

    def sensor_port(self, path: KeyPath) -> str:
        port = self.string(path)
        if port in MOTOR_PORTS:
            raise self.fail(path, f"port {port} is a motor port; sensors are on {', '.join(SENSOR_PORTS)}")
        if port not in SENSOR_PORTS:
            raise self.fail(path, f"unknown sensor port '{port}'; expected one of {', '.join(SENSOR_PORTS)}")
        return port

    def constants(self, path: KeyPath, want: str) -> list[GroundConst]:
        """The ground constants a key names: a name (every instance) or one ground text."""
        key = "".join(str(path[-1]).split())
        pool = self.actions if want == "action" else [gc for gc in self.ground if gc.decl.is_fluent]
        hit = [gc for gc in pool if gc.text == key] or [gc for gc in pool if gc.decl.name == key]
        if hit:
            return hit
        other = [gc for gc in self.ground if gc.text == key or gc.decl.name == key]
        if other:
            kind = other[0].decl.kind
            raise self.fail(path, f"'{key}' is {'an' if kind[0] in 'aeiou' else 'a'} {kind} of {self.domain.path}, "
                            f"not {'an action the robot or the world does' if want == 'action' else 'a fluent'}")
        names = sorted({gc.decl.name for gc in pool})
        raise self.fail(path, f"unknown {want} constant '{key}' ({self.domain.path} has: {', '.join(names)})")

    def value_of(self, path: KeyPath, gc: GroundConst, raw: object) -> object:
        """A fluent value written in TOML (``true``, ``3``, ``"office2"``) in the planner's form."""
        if isinstance(raw, bool):
            value: object = "true" if raw else "false"
        elif isinstance(raw, (int, str)):
            value = raw
        else:
            raise self.fail(path, f"{self.show(path)} must be a value of {gc.text}, not {kind_of(raw)}")
        if value not in gc.domain:
            shown = ", ".join(render_value(v) for v in gc.domain)
            raise self.fail(path, f"{render_value(value)} is not a value of {gc.text} ({shown})")  # type: ignore[arg-type]
        return value

    # -- sections --------------------------------------------------------------------------
    def binding(self) -> RobotBinding:
        allowed = ("format", "bricks", "actions", "events", "sensed")
        for key in self.data:
            if key not in allowed:
                raise self.fail((key,), f"unknown top-level field '{key}'; expected one of: {', '.join(allowed)}")
        fmt = self.string(("format",))
        if fmt != ROBOT_FORMAT:
            raise self.fail(("format",), f"unsupported binding format {fmt!r}; expected {ROBOT_FORMAT!r}")
        bricks = self.bricks()
        actions = self.action_bindings(bricks)
        events = self.event_bindings(bricks, actions)
        actions = self.stop_events(actions, events)
        self.everything_bound(actions, events)
        sensed = self.sensed_bindings(bricks)
        return RobotBinding(self.source.path, bricks, actions, events, sensed)

    def bricks(self) -> dict[str, BrickSpec]:
        out: dict[str, BrickSpec] = {}
        for name in self.table(("bricks",), required=False):
            base: KeyPath = ("bricks", name)
            if not _NAME.match(name):
                raise self.fail(base, f"brick name '{name}' must be a plain name (letters, digits, _)")
            spec = self.table(base, ("sensors", "world"))
            sensors: dict[str, str] = {}
            for port in self.table(base + ("sensors",), required=False):
                self.sensor_port_key(base + ("sensors", port))
                sensors[port] = self.string(base + ("sensors", port), SENSOR_TYPES)
            world = None
            if "world" in spec:
                world = Path(self.source.path).parent / self.string(base + ("world",))
            out[name] = BrickSpec(name, sensors, world, self.loc(base),
                                  self.loc(base + ("world",)) if world else None)
        return out

    def sensor_port_key(self, path: KeyPath) -> None:
        port = str(path[-1])
        if port in MOTOR_PORTS:
            raise self.fail(path, f"port {port} is a motor port; sensors are on {', '.join(SENSOR_PORTS)}")
        if port not in SENSOR_PORTS:
            raise self.fail(path, f"unknown sensor port '{port}'; expected one of {', '.join(SENSOR_PORTS)}")

    def action_bindings(self, bricks: Mapping[str, BrickSpec]) -> dict[GroundConst, ActionBinding]:
        out: dict[GroundConst, ActionBinding] = {}
        for key in self.table(("actions",), required=False):
            base: KeyPath = ("actions", key)
            self.table(base, ("brick", "behaviour", "args", "stop"))
            gcs = self.constants(base, "action")
            brick = self.brick_ref(base + ("brick",), bricks)
            behaviour = self.integer(base + ("behaviour",), 1, 255)
            args: list[int | str] = []
            if self.has(base + ("args",)):
                given = self.array(base + ("args",))
                if len(given) > MAX_ARGS:
                    raise self.fail(base + ("args",), f"{len(given)} arguments: a behaviour takes at most {MAX_ARGS}")
                for i, a in enumerate(given):
                    args.append(self.arg(base + ("args", i), a, gcs))
            for gc in gcs:
                if gc in out:
                    raise self.fail(base, f"{gc.text} is bound twice in [actions]")
                out[gc] = ActionBinding(gc, brick, behaviour, tuple(args), self.loc(base))
        return out

    def arg(self, path: KeyPath, a: object, gcs: list[GroundConst]) -> int | str:
        if isinstance(a, bool) or not isinstance(a, (int, str)):
            raise self.fail(path, f"{self.show(path)} must be an integer or \"$N\", not {kind_of(a)}")
        if isinstance(a, int):
            return self.integer(path, *INT16)
        if not a.startswith("$") or not a[1:]:
            raise self.fail(path, f"{self.show(path)} = {a!r}: write an integer, \"$N\" for the action's N-th "
                            "argument, or \"$name\" for one of its attributes")
        ref = a[1:]
        for gc in gcs:
            if ref.isascii() and ref.isdigit():
                if len(ref) > 3:
                    raise self.fail(path, f"{a}: {gc.text} has {gc.decl.arity} argument(s)")
                n = int(ref)
                if not 1 <= n <= gc.decl.arity:
                    raise self.fail(path, f"{a}: {gc.text} has {gc.decl.arity} argument(s)")
                if not isinstance(gc.args[n - 1], int) or isinstance(gc.args[n - 1], bool):
                    raise self.fail(path, f"{a} of {gc.text} is {render_value(gc.args[n - 1])}, not an integer")
                if not INT16[0] <= gc.args[n - 1] <= INT16[1]:
                    raise self.fail(path, f"{a} of {gc.text} is {gc.args[n - 1]}, outside the int16 a behaviour's "
                                    f"argument travels as ({INT16[0]}..{INT16[1]})")
            else:
                self.attribute_arg(path, a, gc, ref)
        return a

    def attribute_arg(self, path: KeyPath, a: str, gc: GroundConst, ref: str) -> None:
        """``"$name"``: an attribute of the action whose every value is an int16 (found now,
        not at the first action that sends one)."""
        attrs = [ad for ad in gc.decl.attributes if ad.name == ref]
        if not attrs:
            raise self.fail(path, f"{a}: {gc.decl.name} has no attribute '{ref}'")
        for at in attrs[0].instances.values():
            bad = [v for v in at.domain if v != "none" and (isinstance(v, bool) or not isinstance(v, int)
                                                           or not INT16[0] <= v <= INT16[1])]
            if bad:
                raise self.fail(path, f"{a}: attribute {at.text} takes the value {render_value(bad[0])}, "
                                f"not an int16 a behaviour's argument can carry ({INT16[0]}..{INT16[1]})")

    def event_bindings(self, bricks: Mapping[str, BrickSpec],
                       actions: Mapping[GroundConst, ActionBinding]) -> dict[GroundConst, EventBinding]:
        out: dict[GroundConst, EventBinding] = {}
        for key in self.table(("events",), required=False):
            base: KeyPath = ("events", key)
            spec = self.table(base, ("source", "brick", "event", "port", "below", "above"))
            gcs = self.constants(base, "action")
            source = self.string(base + ("source",), EVENT_SOURCES)
            fields: dict[str, Any] = {}
            wanted = {"brick": ("brick", "event"), "sensor": ("brick", "port"), "input": (), "inferred": (),
                      "stop": ()}[source]
            for name in ("brick", "event", "port", "below", "above"):
                if name in spec and name not in wanted and not (source == "sensor" and name in ("below", "above")):
                    raise self.fail(base + (name,), f"'{name}' has no meaning for an event from source '{source}'")
            for name in wanted:
                self.require(base + (name,))
            if "brick" in wanted:
                fields["brick"] = self.brick_ref(base + ("brick",), bricks)
            if source == "brick":
                fields["event"] = self.reported(base + ("event",), Event)
                for gc in gcs:
                    if any(not isinstance(a, int) or isinstance(a, bool) for a in gc.args):
                        raise self.fail(base, f"{gc.text}: a brick reports integer arguments only")
            if source == "sensor":
                port = self.sensor_port(base + ("port",))
                if port not in bricks[fields["brick"]].sensors:
                    raise self.fail(base + ("port",), f"brick '{fields['brick']}' has no sensor on {port} "
                                    "(declare it in its sensors table)")
                fields["port"] = port
                given = [n for n in ("below", "above") if n in spec]
                if len(given) != 1:
                    raise self.fail(base, "an event from a sensor needs exactly one of 'below' or 'above'")
                fields[given[0]] = self.integer(base + (given[0],))
                for gc in gcs:
                    if gc.decl.arity:
                        raise self.fail(base, f"{gc.text}: a sensor event has no arguments")
            for gc in gcs:
                if gc in actions:
                    raise self.fail(base, f"{gc.text} is bound both as the robot's action and as an event")
                if gc in out:
                    raise self.fail(base, f"{gc.text} is bound twice in [events]")
                out[gc] = EventBinding(gc, source, self.loc(base), **fields)
        return out

    def stop_events(self, actions: dict[GroundConst, ActionBinding],
                    events: Mapping[GroundConst, EventBinding]) -> dict[GroundConst, ActionBinding]:
        """Each action's ``stop``: an event without arguments bound with source ``"stop"``."""
        from dataclasses import replace
        stops = {gc.text: gc for gc, e in events.items() if e.source == "stop"}
        for key in self.table(("actions",), required=False):
            path: KeyPath = ("actions", key, "stop")
            if not self.has(path):
                continue
            name = self.string(path)
            if name not in stops:
                raise self.fail(path, f"stop = {name!r}: bind the event {name} with source = \"stop\" in [events] "
                                f"(events from source stop: {', '.join(sorted(stops)) or 'none'})")
            for gc in self.constants(("actions", key), "action"):
                actions[gc] = replace(actions[gc], stop=stops[name])
        return actions

    def everything_bound(self, actions: Mapping, events: Mapping) -> None:
        for gc in self.actions:
            if gc not in actions and gc not in events:
                where = gc.decl.loc
                raise BindingError(f"action '{gc.text}' has no binding in {self.source.path}: add [actions."
                                   f"{gc.decl.name}] (a behaviour of a brick) or [events.{gc.decl.name}] "
                                   "(and where it comes from)", where)

    def sensed_bindings(self, bricks: Mapping[str, BrickSpec]) -> dict[GroundConst, SensedBinding]:
        out: dict[GroundConst, SensedBinding] = {}
        for key in self.table(("sensed",), required=False):
            base: KeyPath = ("sensed", key)
            spec = self.table(base, ("brick", "value", "port", "thresholds", "values", "map", "ignore"))
            gcs = self.constants(base, "fluent")
            if len(gcs) != 1:
                raise self.fail(base, f"'{key}' names {len(gcs)} fluents; bind each ground fluent "
                                f"(e.g. [sensed.\"{gcs[0].text}\"])")
            gc = gcs[0]
            brick = self.brick_ref(base + ("brick",), bricks)
            fields: dict[str, Any] = {}
            if ("value" in spec) == ("port" in spec):
                raise self.fail(base, "a sensed fluent needs exactly one of 'value' (a sensing value of the brick's "
                                "behaviours) or 'port' (a sensor the PC reads)")
            if "value" in spec:
                fields["value"] = self.reported(base + ("value",), Sense)
            else:
                port = self.sensor_port(base + ("port",))
                if port not in bricks[brick].sensors:
                    raise self.fail(base + ("port",), f"brick '{brick}' has no sensor on {port} "
                                    "(declare it in its sensors table)")
                fields["port"] = port
            if "thresholds" in spec or "values" in spec:
                if "map" in spec:
                    raise self.fail(base + ("map",), "give either thresholds and values, or a map, not both")
                ts = [self.integer(base + ("thresholds", i)) for i in range(len(self.array(base + ("thresholds",))))]
                if any(b <= a for a, b in zip(ts, ts[1:])) or not ts:
                    raise self.fail(base + ("thresholds",), "thresholds must be one or more increasing integers")
                vs = self.array(base + ("values",))
                if len(vs) != len(ts) + 1:
                    raise self.fail(base + ("values",), f"{len(ts)} threshold(s) need {len(ts) + 1} values, "
                                    f"not {len(vs)}")
                fields["thresholds"] = tuple(ts)
                fields["values"] = tuple(self.value_of(base + ("values", i), gc, v) for i, v in enumerate(vs))
            if "map" in spec:
                table = {}
                for k in self.table(base + ("map",)):
                    path = base + ("map", k)
                    reading = _reading(k)
                    if reading is None:
                        raise self.fail(path, f"map key '{k[:40]}' must be an integer reading, written in ASCII "
                                        f"digits ({_INT32[0]}..{_INT32[1]})")
                    table[reading] = self.value_of(path, gc, self.get(path))
                fields["table"] = table
            if "ignore" in spec:
                n = len(self.array(base + ("ignore",)))
                fields["ignore"] = frozenset(self.integer(base + ("ignore", i)) for i in range(n))
            if not fields.get("thresholds") and not fields.get("table") and not gc.boolean \
                    and not any(isinstance(v, int) for v in gc.domain):
                raise self.fail(base, f"{gc.text} has no integer values: map the readings with thresholds/values or "
                                "a map table")
            out[gc] = SensedBinding(gc, brick, self.loc(base), **fields)
        return out


def _reading(key: str) -> int | None:
    """A ``map`` key as a reading: an optional minus and ASCII digits in int32 (``int`` would
    also take ``"٣"``, ``" 3"`` and ``"1_0"``, and raise on ten thousand digits)."""
    digits = key[1:] if key.startswith("-") else key
    if not digits or len(digits) > 10 or any(c not in "0123456789" for c in digits):
        return None
    value = int(key)
    return value if _INT32[0] <= value <= _INT32[1] else None
