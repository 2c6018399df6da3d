"""What a server accepts: requests in a domain's terms, and the events they become.

A goal request is an event whose effect is a fluent, and the standing goal says that nothing
is pending (``docs/online.md``). The file ``requests.toml`` beside a domain (format
``cplus.requests/1``) says which request texts a client may send, which events each one
becomes, what a cancellation is, and which fluent tells that a goal is still open. The mail
robot's::

    format = "cplus.requests/1"
    slots = "package"                 # each goal in flight holds one object of this sort
    open = "pending($slot)"           # a Boolean fluent: true while the goal is not done
    cancel = ["cancel($slot)"]        # the events of a cancellation

    [requests]
    deliver = ["request($slot,$1)", "address($slot,$2)"]    # deliver(FROM,TO)

A request ``deliver(office3,office2)`` given the slot 1 becomes the events
``request(1,office3)`` and ``address(1,office2)``: ``$slot`` is the goal's slot, ``$1``,
``$2``... the request's arguments, checked against the sorts of the places they fill. A
request that the domain cannot express (an unknown name, a wrong number of arguments, an
object outside its sort, text that does not parse) is :class:`Rejected` with a reason that
says what would be accepted. Errors in the file itself are :class:`RequestsError`, located
(``requests.toml:7:11: error: ...``).

>>> from cplus.api import Domain
>>> d = Domain.from_text('''
... :- sorts office; slot.
... :- objects a, b :: office; 1..2 :: slot.
... :- variables S :: slot; O :: office.
... :- constants open(slot) :: inertialFluent; at(slot) :: inertialFluent(office*);
...   ask(slot,office), drop(slot) :: exogenousAction.
... ask(S,O) causes open(S) & at(S)=O.  drop(S) causes -open(S).''')
>>> v = parse_requests('''format = "cplus.requests/1"
... slots = "slot"
... open = "open($slot)"
... cancel = ["drop($slot)"]
... [requests]
... fetch = ["ask($slot,$1)"]''', "requests.toml", d)
>>> v.events("fetch(b)", 2)
['ask(2,b)']
>>> v.events("fetch(c)", 1)
Traceback (most recent call last):
...
cplus.robot.serving.vocabulary.Rejected: c is not an office (a, b)
"""
from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cplus.errors import CPlusError, Location, Source
from cplus.signature import ConstDecl, GroundConst, NamedSort, render_value
from trajectory.toml_locations import KeyPath, locate_keys, nearest_location, toml_error

__all__ = ["MAX_REQUEST", "REQUESTS_FORMAT", "Rejected", "RequestForm", "RequestVocabulary", "RequestsError", "load_requests",
           "parse_requests", "requests_beside"]

REQUESTS_FORMAT = "cplus.requests/1"
_NAME = re.compile(r"[a-z][A-Za-z0-9_]*\Z")

MAX_REQUEST = 1000
"""The longest request text read (characters): a longer one is rejected before it is parsed,
so that a client's request costs the server a bounded amount of work."""
MAX_ARGUMENT = 32
"""The highest ``$N`` a requests file may use."""
MAX_REQUESTS_FILE = 1 << 20
"""The largest requests file read (bytes)."""


def _term(text: str) -> tuple[str, str | None] | None:
    """``name`` or ``name(inner)`` with blanks around: (name, inner or None), or None when the
    text is neither. One pass over the text (a regex with two adjacent ``\\s*`` took time
    quadratic in a run of blanks: 60,000 of them, a minute)."""
    s = text.strip()
    i = 0
    while i < len(s) and s[i].isascii() and (s[i].isalnum() or s[i] == "_"):
        i += 1
    if i == 0:
        return None
    rest = s[i:].lstrip()
    if not rest:
        return s[:i], None
    if rest[0] != "(" or rest[-1] != ")":
        return None
    return s[:i], rest[1:-1]


class RequestsError(CPlusError):
    """A ``requests.toml`` that is malformed or does not fit its domain."""


class Rejected(Exception):
    """A request the domain cannot express; the message says why and what would do."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def requests_beside(domain_path: str) -> str | None:
    """The ``requests.toml`` beside a domain file, if there is one."""
    beside = Path(domain_path).resolve().parent / "requests.toml"
    return str(beside) if beside.is_file() else None


@dataclass(frozen=True)
class _Template:
    """An event or fluent written with ``$slot`` and ``$N`` holes: ``request($slot,$1)``."""

    decl: ConstDecl
    args: tuple[object, ...]          # "$slot", an int N (the request's N-th argument), or an object

    def ground(self, slot: object, values: Sequence[object]) -> GroundConst:
        args = tuple(slot if a == "$slot" else values[a - 1] if isinstance(a, int) else a for a in self.args)
        return self.decl.instances[args]


@dataclass(frozen=True)
class RequestForm:
    """One kind of request: its name, the sort of each argument, the events it becomes."""

    name: str
    sorts: tuple[tuple[object, ...], ...]     # the objects each argument may be
    sort_names: tuple[str, ...]
    events: tuple[_Template, ...]

    def usage(self) -> str:
        """``deliver(office,office)``."""
        return f"{self.name}({','.join(self.sort_names)})" if self.sort_names else self.name


class RequestVocabulary:
    """A validated ``requests.toml``: the requests a domain accepts (:meth:`events`), the
    slots goals occupy, the fluent that says a goal is open, and the cancellation's events."""

    def __init__(self, path: str, slot_sort: str, slots: tuple[object, ...], open_fluent: _Template,
                 cancel: tuple[_Template, ...], forms: Mapping[str, RequestForm]) -> None:
        self.path = path
        self.slot_sort = slot_sort
        self.slots = slots
        self._open = open_fluent
        self._cancel = cancel
        self.forms = dict(forms)

    def usage(self) -> str:
        """The requests accepted: ``deliver(office,office)``."""
        return ", ".join(f.usage() for f in self.forms.values())

    def parse(self, text: str) -> tuple[RequestForm, tuple[object, ...]]:
        """The form of a request text and its arguments as domain objects; :class:`Rejected`
        when the domain cannot express it."""
        if not isinstance(text, str) or not text.strip():
            raise Rejected(f"an empty request; this domain accepts {self.usage()}")
        if len(text) > MAX_REQUEST:
            raise Rejected(f"a request of {len(text)} characters; a request has at most {MAX_REQUEST}, such as "
                           f"{self.usage()}")
        term = _term(text)
        if term is None:
            raise Rejected(f"cannot read {text!r} as a request such as {self.usage()}")
        name, inner = term
        form = self.forms.get(name)
        if form is None:
            raise Rejected(f"unknown request '{name}'; this domain accepts {self.usage()}")
        args = _split_args(inner) if inner is not None else []
        if args is None:
            raise Rejected(f"cannot read the arguments of {text!r}; write {form.usage()}")
        if len(args) != len(form.sorts):
            raise Rejected(f"{name} takes {len(form.sorts)} argument{'s' if len(form.sorts) != 1 else ''} "
                           f"({form.usage()}), not {len(args)}")
        values = []
        for arg, objects, sort in zip(args, form.sorts, form.sort_names):
            value = next((o for o in objects if render_value(o) == arg), None)  # type: ignore[arg-type]
            if value is None:
                shown = ", ".join(render_value(o) for o in objects[:12]) + (", ..." if len(objects) > 12 else "")  # type: ignore[arg-type]
                raise Rejected(f"{arg or 'an empty argument'} is not {_article(sort)} {sort} ({shown})")
            values.append(value)
        return form, tuple(values)

    def events(self, text: str, slot: object) -> list[str]:
        """The events that a request becomes, given the goal's slot; :class:`Rejected` when
        the domain cannot express it."""
        return self.ground(self.parse(text), slot)

    def ground(self, parsed: tuple[RequestForm, tuple[object, ...]], slot: object) -> list[str]:
        """The events of a request already parsed (:meth:`parse`), given the goal's slot."""
        form, values = parsed
        return [t.ground(slot, values).text for t in form.events]

    def cancel_events(self, slot: object) -> list[str]:
        return [t.ground(slot, ()).text for t in self._cancel]

    def open_fluent(self, slot: object) -> GroundConst:
        """The Boolean fluent that is true while the goal in ``slot`` is not done."""
        return self._open.ground(slot, ())

    def event_constants(self) -> frozenset[GroundConst]:
        """Every ground event a request or a cancellation can become (the server's events)."""
        decls = {t.decl for f in self.forms.values() for t in f.events} | {t.decl for t in self._cancel}
        return frozenset(gc for d in decls for gc in d.instances.values())


def _split_args(inner: str) -> list[str] | None:
    """Top-level comma-separated arguments, blanks removed (None: unbalanced parentheses)."""
    out: list[str] = []
    cur: list[str] = []
    depth = 0
    for ch in inner:
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
            if depth < 0:
                return None
        if ch == "," and depth == 0:
            out.append("".join(cur).strip())
            cur = []
        elif not ch.isspace():
            cur.append(ch)
    if depth:
        return None
    out.append("".join(cur).strip())
    return out


def _article(word: str) -> str:
    return "an" if word[:1] in "aeiou" else "a"


def load_requests(path: str, domain) -> RequestVocabulary:
    """Read and validate a ``requests.toml`` against a domain (:class:`cplus.api.Domain`)."""
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_REQUESTS_FILE + 1)
    except OSError as exc:
        raise RequestsError(f"cannot read requests file {path}: {exc.strerror or exc}") from None
    if len(data) > MAX_REQUESTS_FILE:
        raise RequestsError(f"requests file {path} is larger than {MAX_REQUESTS_FILE >> 20} MiB: it names a few "
                            "requests, not data")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise RequestsError(f"requests file {path} is not UTF-8 text: {exc.reason}") from None
    return parse_requests(text, path, domain)


def parse_requests(text: str, path: str, domain) -> RequestVocabulary:
    """Validate the text of a requests file against a domain. Raises :class:`RequestsError`."""
    source = Source(path, text)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message, line, col = toml_error(exc)
        raise RequestsError(message, Location.of_token(source, line, col)) from None
    return _Reader(source, data, locate_keys(text), domain).vocabulary()


class _Reader:
    def __init__(self, source: Source, data: dict[str, Any], locations: dict[KeyPath, tuple[int, int]], domain):
        self.source = source
        self.data = data
        self.locations = locations
        self.domain = domain
        self.sig = domain.program.signature

    def fail(self, path: KeyPath, message: str) -> RequestsError:
        return RequestsError(message, self.loc(path))

    def loc(self, path: KeyPath) -> Location:
        return Location.of_token(self.source, *nearest_location(self.locations, path))

    def string(self, path: KeyPath) -> str:
        node: Any = self.data
        for part in path:
            if not isinstance(node, dict) or part not in node:
                where = ".".join(map(str, path[:-1])) or "the top level"
                raise self.fail(path[:-1], f"missing required field '{path[-1]}' in {where}")
            node = node[part]
        if not isinstance(node, str):
            raise self.fail(path, f"{'.'.join(map(str, path))} must be a string, not {type(node).__name__}")
        return node

    def strings(self, path: KeyPath) -> list[str]:
        node: Any = self.data
        for part in path:
            node = node.get(part) if isinstance(node, dict) else None
        if node is None:
            where = ".".join(map(str, path[:-1])) or "the top level"
            raise self.fail(path[:-1], f"missing required field '{path[-1]}' in {where}")
        if isinstance(node, str):
            node = [node]
        if not isinstance(node, list) or not node or not all(isinstance(x, str) for x in node):
            raise self.fail(path, f"{'.'.join(map(str, path))} must be a list of events such as \"cancel($slot)\"")
        return node

    def vocabulary(self) -> RequestVocabulary:
        allowed = ("format", "slots", "open", "cancel", "requests")
        for key in self.data:
            if key not in allowed:
                raise self.fail((key,), f"unknown top-level field '{key}'; expected one of: {', '.join(allowed)}")
        fmt = self.string(("format",))
        if fmt != REQUESTS_FORMAT:
            raise self.fail(("format",), f"unsupported requests format {fmt!r}; expected {REQUESTS_FORMAT!r}")
        sort = self.string(("slots",))
        if sort not in self.sig.sorts:
            raise self.fail(("slots",), f"unknown sort '{sort}' ({self.domain.path} has: "
                            f"{', '.join(s for s in self.sig.sorts if s not in ('boolean',))})")
        slots = tuple(o for o in self.sig.objects_of(NamedSort(sort)) if o != "none")
        if not slots:
            raise self.fail(("slots",), f"sort '{sort}' has no objects: no goal could ever be in flight")
        open_t = self.template(("open",), self.string(("open",)), "fluent", slots, None)
        cancel = tuple(self.template(("cancel", i), t, "event", slots, None)
                       for i, t in enumerate(self.strings(("cancel",))))
        forms: dict[str, RequestForm] = {}
        table = self.data.get("requests")
        if not isinstance(table, dict) or not table:
            raise self.fail(("requests",), "a [requests] table naming at least one request is required, such as "
                            "deliver = [\"request($slot,$1)\"]")
        for name in table:
            if not _NAME.match(name):
                raise self.fail(("requests", name), f"request name '{name}' must start with a lower-case letter "
                                "(letters, digits, _)")
            sorts: dict[int, tuple[tuple[object, ...], str]] = {}
            templates = tuple(self.template(("requests", name, i), t, "event", slots, sorts)
                              for i, t in enumerate(self.strings(("requests", name))))
            if not any("$slot" in t.args for t in templates):
                raise self.fail(("requests", name), f"the events of request {name} must mention $slot (the goal "
                                "they belong to)")
            n = max(sorts, default=0)
            missing = [k for k in range(1, n + 1) if k not in sorts]
            if missing:
                raise self.fail(("requests", name), f"request {name} uses ${n} but not ${missing[0]}")
            forms[name] = RequestForm(name, tuple(sorts[k][0] for k in range(1, n + 1)),
                                      tuple(sorts[k][1] for k in range(1, n + 1)), templates)
        return RequestVocabulary(self.source.path, sort, slots, open_t, cancel, forms)

    def template(self, path: KeyPath, text: str, want: str, slots: tuple[object, ...],
                 sorts: dict[int, tuple[tuple[object, ...], str]] | None) -> _Template:
        term = _term(text)
        args = _split_args(term[1]) if term is not None and term[1] is not None else []
        if term is None or args is None:
            raise self.fail(path, f"cannot read {text!r}: write a constant with arguments $slot, $1, $2, ... or "
                            "objects, such as \"request($slot,$1)\"")
        name = term[0]
        decl = self.sig.lookup(name, len(args))
        if decl is None or decl.hidden:
            known = sorted({d.name for d in self.sig.constants.values() if not d.hidden and
                            (d.is_fluent if want == "fluent" else d.kind in ("exogenousAction", "action"))})
            raise self.fail(path, f"{self.domain.path} has no {want} {name}/{len(args)} "
                            f"({want}s: {', '.join(known) or 'none'})")
        if want == "fluent" and not (decl.is_fluent and self.sig.objects_of(decl.domain) == ("true", "false")):
            raise self.fail(path, f"{name} must be a Boolean fluent (true while the goal is open), not "
                            f"{_article(decl.kind)} {decl.kind} of {', '.join(map(str, self.sig.objects_of(decl.domain)))}")
        if want == "event" and decl.kind not in ("exogenousAction", "action"):
            raise self.fail(path, f"{name} is {_article(decl.kind)} {decl.kind}, not an event (an exogenous action)")
        if want == "event" and self.sig.objects_of(decl.domain) != ("true", "false"):
            raise self.fail(path, f"{name} must be a Boolean action to be an event")
        out: list[object] = []
        for i, (arg, sort) in enumerate(zip(args, decl.argsorts)):
            objects = self.sig.objects_of(sort)
            if arg == "$slot":
                outside = [s for s in slots if s not in objects]
                if outside:
                    raise self.fail(path, f"argument {i + 1} of {name} is {sort}, and slot {render_value(outside[0])} "  # type: ignore[arg-type]
                                    "is not one of its objects")
                out.append("$slot")
            elif arg.startswith("$"):
                digits = arg[1:]
                if sorts is None or not (digits.isascii() and digits.isdigit()) or not 1 <= int(digits[:4]) <= \
                        MAX_ARGUMENT or len(digits) > 4:
                    what = "$slot" if sorts is None else f"$slot, $1, $2, ... (up to ${MAX_ARGUMENT})"
                    raise self.fail(path, f"{arg}: only {what} may appear here")
                k = int(arg[1:])
                allowed = tuple(o for o in objects if o != "none")
                if k in sorts and sorts[k][0] != allowed:
                    raise self.fail(path, f"${k} fills places of two different sorts ({sorts[k][1]} and {sort})")
                sorts[k] = (allowed, str(sort).rstrip("*"))
                out.append(k)
            else:
                value = next((o for o in objects if render_value(o) == arg), None)
                if value is None:
                    raise self.fail(path, f"{arg} is not an object of {sort} (argument {i + 1} of {name})")
                out.append(value)
        if sorts is None and "$slot" not in out:
            raise self.fail(path, f"{text} must mention $slot (which goal it is about)")
        return _Template(decl, tuple(out))
