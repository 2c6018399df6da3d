"""Batch job files: TOML, JSON lines, or a folder of domains, read into :class:`Job` records.

A job is one ``cplus plan`` run: a domain file, optionally one query (or nmquery) label, a
scene, a solver, planner options, a time and a memory limit, whether to keep the plan.  Paths
are relative to the job file's folder.  TOML::

    [defaults]                 # optional: every job's values unless it gives its own
    timeout = 60               # seconds
    memory = 2048              # MB
    solver = "glucose4"

    [[job]]
    id = "bw-20"               # optional: the domain's name and the query's label
    domain = "data/bw-20.cp"
    query = "0"                # optional: every query of the file
    options = { max_horizon = 40 }

JSON lines: one object per line with the same keys (a line ``{"defaults": {...}}`` sets the
defaults of the lines after it).  A folder: every ``*.cp`` file under it, one job each,
every query of the file, the defaults from the command line.

Every mistake is one located line (``jobs.toml:12: unknown key 'timout'``), raised as
:class:`BatchError` before anything runs: the values are checked as ``cplus plan`` checks its
flags (:mod:`cplus.options`), so a batch refuses what the command refuses.
"""
from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, field

from cplus.errors import CPlusError
from cplus.options import (
    PLAN_OPTIONS,
    OptionError,
    check_label,
    check_memory,
    check_plan_options,
    check_portfolio,
    check_solver,
    check_timeout,
)

__all__ = ["BatchError", "Job", "read_jobs", "OPTIONS", "KEYS"]


class BatchError(CPlusError):
    """A job file that cannot be run as written (one line)."""

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message

    def render(self) -> str:
        return f"cplus batch: error: {self.message}"

    def __str__(self) -> str:
        return self.message


OPTIONS = PLAN_OPTIONS
"""Planner options a job may set (``cplus plan``'s flags, with ``_`` for ``-``), each with
its check (:data:`cplus.options.PLAN_OPTIONS`)."""

KEYS = {"id", "domain", "query", "nmquery", "scene", "solver", "options", "timeout", "memory", "plans", "portfolio"}


@dataclass
class Job:
    """One run. ``timeout`` in seconds and ``memory`` in MB (None: no limit); ``portfolio``:
    solvers (or strategies ``sequential``/``A``/``B``) raced on the job, the first answer wins;
    ``nmquery``: ``query`` is the label of an nmquery."""

    id: str
    domain: str
    query: str | None = None
    scene: str | None = None
    solver: str | None = None
    options: dict = field(default_factory=dict)
    timeout: float | None = None
    memory: int | None = None
    plans: bool = False
    portfolio: list[str] = field(default_factory=list)
    nmquery: bool = False

    def to_dict(self) -> dict:
        return asdict(self)


def read_jobs(path: str, defaults: dict | None = None) -> list[Job]:
    """The jobs of a TOML or JSON-lines file, or of a folder of domains.  ``defaults``: the
    command line's values (already checked), under the file's own ``[defaults]``."""
    base = dict(defaults or {})
    if os.path.isdir(path):
        jobs = []
        for root, dirs, files in os.walk(path):
            dirs.sort()
            for f in sorted(files):
                if f.endswith(".cp"):
                    full = os.path.join(root, f)
                    rel = os.path.relpath(full, path)
                    jobs.append(_job({"domain": rel}, base, path, _Where(os.path.join(path, rel))))
        if not jobs:
            raise BatchError(f"{path}: no *.cp file in this folder")
        return _unique(jobs, path)
    if not os.path.isfile(path):
        raise BatchError(f"{path}: no such file or folder")
    try:
        with open(path, encoding="utf-8") as fh:
            text = fh.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise BatchError(f"{path}: cannot be read ({exc})") from None
    folder = os.path.dirname(os.path.abspath(path))
    if path.endswith(".toml"):
        return _unique(_toml(text, path, folder, base), path)
    return _unique(_jsonl(text, path, folder, base), path)


class _Where:
    """Where a job (or the defaults) is written, for a message: ``jobs.jsonl:3``, or the line
    of one of its keys in a TOML file (``jobs.toml:12``, found in the text of its table)."""

    def __init__(self, path: str, line: int | None = None, keys: dict[str, int] | None = None) -> None:
        self.path = path
        self.line = line
        self.keys = keys or {}

    def at(self, *keys: str) -> str:
        line = next((self.keys[k] for k in keys if k in self.keys), self.line)
        return self.path if line is None else f"{self.path}:{line}"

    def __str__(self) -> str:
        return self.at()


def _toml_tables(text: str, path: str) -> tuple[_Where, list[_Where]]:
    """The ``[defaults]`` table's place and each ``[[job]]``'s, with the line of each key
    written in it (``key = ...``, also inside an inline table or a ``[job.options]``)."""
    import re
    lines = text.splitlines()
    heads = [(i, line.strip()) for i, line in enumerate(lines)
             if re.match(r"\s*\[\s*\[\s*job\s*\]\s*\]|\s*\[\s*defaults\s*\]", line)]
    key = re.compile(r"(?:^|[{,\s])\"?([A-Za-z_][A-Za-z0-9_-]*)\"?\s*=")
    defaults = _Where(path)
    jobs = []
    for n, (i, head) in enumerate(heads):
        end = heads[n + 1][0] if n + 1 < len(heads) else len(lines)
        keys: dict[str, int] = {}
        for j in range(i + 1, end):
            for k in key.findall(lines[j].split("#", 1)[0]):
                keys.setdefault(k, j + 1)
        where = _Where(path, i + 1, keys)
        if "defaults" in head:
            defaults = where
        else:
            jobs.append(where)
    return defaults, jobs


def _toml(text: str, path: str, folder: str, base: dict) -> list[Job]:
    import tomllib
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise BatchError(f"{path}: {exc}") from None
    unknown = set(data) - {"defaults", "job"}
    if unknown:
        raise BatchError(f"{path}: unknown table '{sorted(unknown)[0]}' (expected [defaults] and [[job]])")
    at_defaults, at_jobs = _toml_tables(text, path)
    defaults = dict(base)
    if "defaults" in data:
        if not isinstance(data["defaults"], dict):
            raise BatchError(f"{path}: [defaults] must be a table")
        defaults.update(_check(data["defaults"], at_defaults, defaults_only=True))
    entries = data.get("job", [])
    if not isinstance(entries, list) or not entries:
        raise BatchError(f"{path}: no [[job]] entries")
    return [_job(e, defaults, folder, at_jobs[k] if k < len(at_jobs) else _Where(f"{path}: job {k + 1}"))
            for k, e in enumerate(entries)]


def _jsonl(text: str, path: str, folder: str, base: dict) -> list[Job]:
    defaults = dict(base)
    jobs = []
    for lineno, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        where = _Where(path, lineno)
        try:
            entry = json.loads(line)
        except json.JSONDecodeError as exc:
            raise BatchError(f"{where}: not JSON ({exc.msg})") from None
        except ValueError as exc:        # an integer of thousands of digits
            raise BatchError(f"{where}: not JSON ({exc})") from None
        if not isinstance(entry, dict):
            raise BatchError(f"{where}: a job must be a JSON object")
        if set(entry) == {"defaults"}:
            if not isinstance(entry["defaults"], dict):
                raise BatchError(f"{where}: defaults must be an object")
            defaults.update(_check(entry["defaults"], where, defaults_only=True))
            continue
        jobs.append(_job(entry, defaults, folder, where))
    if not jobs:
        raise BatchError(f"{path}: no jobs (one JSON object per line, or a .toml file)")
    return jobs


def _check(entry: dict, where: _Where, defaults_only: bool = False) -> dict:
    """The keys of a job (or of the defaults) known, and each value within its bounds, as
    ``cplus plan`` checks its flags (:mod:`cplus.options`)."""
    for k in entry:
        if k not in KEYS or (defaults_only and k in ("id", "domain")):
            raise BatchError(f"{where.at(k)}: unknown key {k!r}{_close(k, KEYS)} (keys: {', '.join(sorted(KEYS))})")
    checks = {"timeout": check_timeout, "memory": check_memory, "solver": check_solver, "portfolio": _portfolio,
              "query": check_label, "nmquery": check_label, "plans": _flag}
    out = dict(entry)
    for k, check in checks.items():
        if k in entry:
            try:
                out[k] = check(entry[k])
            except OptionError as exc:
                raise BatchError(f"{where.at(k)}: {k!r}: {exc.message}") from None
    for k in ("scene", "domain", "id"):
        v = entry.get(k)
        if k in entry and not (isinstance(v, str) and v) and not (k == "id" and isinstance(v, int)):
            raise BatchError(f"{where.at(k)}: {k!r} must be " + ("a name" if k == "id" else "a file name"))
    if "options" in entry:
        if not isinstance(entry["options"], dict):
            raise BatchError(f"{where.at('options')}: 'options' must be a table of cplus plan options")
        for k, v in entry["options"].items():
            option = PLAN_OPTIONS.get(k)
            if option is None:
                raise BatchError(f"{where.at(k, 'options')}: unknown option {k!r}{_close(k, PLAN_OPTIONS)} "
                                 f"(options: {', '.join(sorted(PLAN_OPTIONS))})")
            try:
                option(v)
            except OptionError as exc:
                raise BatchError(f"{where.at(k, 'options')}: option {k!r}: {exc.message}") from None
    return out


def _portfolio(value: object) -> list[str]:
    if isinstance(value, str):          # "glucose4,minisat22", as on the command line
        value = value.split(",")
    return check_portfolio(value)


def _flag(value: object) -> bool:
    if not isinstance(value, bool):
        raise OptionError(f"expected true or false, got {value!r}")
    return value


def _close(word: str, names) -> str:
    import difflib
    match = difflib.get_close_matches(word, list(names), n=1, cutoff=0.75)
    return f" (did you mean {match[0]!r}?)" if match else ""


def _job(entry: dict, defaults: dict, folder: str, where: _Where) -> Job:
    entry = _check(entry, where)
    e = {**defaults, **entry}
    if "options" in defaults and "options" in entry:
        e["options"] = {**defaults["options"], **entry["options"]}
    domain = e.get("domain")
    if not isinstance(domain, str) or not domain:
        raise BatchError(f"{where}: a job needs 'domain', a file name")
    full = domain if os.path.isabs(domain) else os.path.join(folder, domain)
    if not os.path.isfile(full):
        raise BatchError(f"{where.at('domain')}: domain {domain}: no such file")
    if "query" in e and "nmquery" in e:
        raise BatchError(f"{where.at('nmquery')}: give 'query' or 'nmquery', not both")
    nm = "nmquery" in e
    query = e.get("nmquery") if nm else e.get("query")
    scene = e.get("scene")
    if scene is not None:
        scene = scene if os.path.isabs(scene) else os.path.join(folder, scene)
        if not os.path.isfile(scene):
            raise BatchError(f"{where.at('scene')}: scene {e['scene']}: no such file")
    options = dict(e.get("options", {}))
    try:
        options = check_plan_options(options)
    except OptionError as exc:
        raise BatchError(f"{where.at(exc.key or 'options', 'options')}: {exc.message}") from None
    if "extern" in options:
        options["extern"] = [x if os.path.isabs(x) else os.path.join(folder, x) for x in options["extern"]]
        missing = next((x for x in options["extern"] if not os.path.isfile(x)), None)
        if missing is not None:
            raise BatchError(f"{where.at('extern', 'options')}: option 'extern': {missing}: no such file")
    robot = scene is not None or os.path.isfile(os.path.join(os.path.dirname(os.path.abspath(full)), "scene.toml"))
    if robot and options.get("n", 1) != 1:
        raise BatchError(f"{where.at('n', 'options')}: option 'n' applies to plain domains; a robot task yields "
                         "one refined plan")
    if robot and nm:
        raise BatchError(f"{where.at('nmquery')}: 'nmquery' applies to plain domains; a robot task refines the "
                         "plans of its queries")
    ident = e.get("id")
    if ident is None:
        rel = os.path.relpath(full, folder)
        name = os.path.basename(domain) if rel.startswith("..") or os.path.isabs(domain) else rel
        ident = os.path.splitext(name)[0] + (f"#{query}" if query is not None else "")
    memory = e.get("memory")
    return Job(str(ident), os.path.abspath(full), query, scene and os.path.abspath(scene), e.get("solver"), options,
               e.get("timeout"), memory, e.get("plans", False), e.get("portfolio", []), nm)


def _unique(jobs: list[Job], path: str) -> list[Job]:
    seen: set[str] = set()
    for j in jobs:
        if j.id in seen:
            raise BatchError(f"{path}: two jobs have the id '{j.id}' (ids name results: give each an 'id')")
        seen.add(j.id)
    return jobs
