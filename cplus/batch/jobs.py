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

Every mistake is one located line (``jobs.toml: job 3: unknown key 'timout'``), raised as
:class:`BatchError` before anything runs.
"""
from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, field
from typing import Any

from cplus.errors import CPlusError

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


OPTIONS: dict[str, Any] = {"n": int, "max_horizon": int, "jobs": (int, str), "strategy": str, "gamma": (int, float),
           "any_length": bool, "nogoods": str, "eager": str, "max_iterations": int, "extern": list}
"""Planner options a job may set (``cplus plan``'s flags, with ``_`` for ``-``)."""

KEYS = {"id", "domain", "query", "nmquery", "scene", "solver", "options", "timeout", "memory", "plans", "portfolio"}


@dataclass
class Job:
    """One run. ``timeout`` in seconds and ``memory`` in MB (None: no limit); ``portfolio``:
    solvers (or strategies ``sequential``/``A``/``B``) raced on the job, the first answer wins."""

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

    def to_dict(self) -> dict:
        return asdict(self)


def read_jobs(path: str, defaults: dict | None = None) -> list[Job]:
    """The jobs of a TOML or JSON-lines file, or of a folder of domains.  ``defaults``: the
    command line's values, under the file's own ``[defaults]``."""
    base = dict(defaults or {})
    if os.path.isdir(path):
        jobs = []
        for root, dirs, files in os.walk(path):
            dirs.sort()
            for f in sorted(files):
                if f.endswith(".cp"):
                    full = os.path.join(root, f)
                    jobs.append(_job({"domain": os.path.relpath(full, path)}, base, path, os.path.relpath(full, path)))
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


def _toml(text: str, path: str, folder: str, base: dict) -> list[Job]:
    import tomllib
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise BatchError(f"{path}: {exc}") from None
    unknown = set(data) - {"defaults", "job"}
    if unknown:
        raise BatchError(f"{path}: unknown table '{sorted(unknown)[0]}' (expected [defaults] and [[job]])")
    defaults = dict(base)
    if "defaults" in data:
        if not isinstance(data["defaults"], dict):
            raise BatchError(f"{path}: [defaults] must be a table")
        defaults.update(_check(data["defaults"], f"{path}: [defaults]", defaults_only=True))
    entries = data.get("job", [])
    if not isinstance(entries, list) or not entries:
        raise BatchError(f"{path}: no [[job]] entries")
    return [_job(e, defaults, folder, f"{path}: job {k}") for k, e in enumerate(entries, 1)]


def _jsonl(text: str, path: str, folder: str, base: dict) -> list[Job]:
    defaults = dict(base)
    jobs = []
    for lineno, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        where = f"{path}:{lineno}"
        try:
            entry = json.loads(line)
        except json.JSONDecodeError as exc:
            raise BatchError(f"{where}: not JSON ({exc.msg})") from None
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


def _check(entry: dict, where: str, defaults_only: bool = False) -> dict:
    for k in entry:
        if k not in KEYS or (defaults_only and k in ("id", "domain")):
            raise BatchError(f"{where}: unknown key '{k}' (keys: {', '.join(sorted(KEYS))})")
    return entry


def _job(entry: dict, defaults: dict, folder: str, where: str) -> Job:
    _check(entry, where)
    e = {**defaults, **entry}
    if "options" in defaults and "options" in entry:
        e["options"] = {**defaults["options"], **entry["options"]}
    domain = e.get("domain")
    if not isinstance(domain, str) or not domain:
        raise BatchError(f"{where}: a job needs 'domain', a file name")
    full = domain if os.path.isabs(domain) else os.path.join(folder, domain)
    if not os.path.isfile(full):
        raise BatchError(f"{where}: domain {domain}: no such file")
    if "query" in e and "nmquery" in e:
        raise BatchError(f"{where}: give 'query' or 'nmquery', not both")
    query = e.get("query", e.get("nmquery"))
    if query is not None:
        query = str(query)
    scene = e.get("scene")
    if scene is not None:
        if not isinstance(scene, str):
            raise BatchError(f"{where}: 'scene' must be a file name")
        scene = scene if os.path.isabs(scene) else os.path.join(folder, scene)
        if not os.path.isfile(scene):
            raise BatchError(f"{where}: scene {e['scene']}: no such file")
    options = e.get("options", {})
    if not isinstance(options, dict):
        raise BatchError(f"{where}: 'options' must be a table of cplus plan options")
    for k, v in options.items():
        kind = OPTIONS.get(k)
        if kind is None:
            raise BatchError(f"{where}: unknown option '{k}' (options: {', '.join(sorted(OPTIONS))})")
        if not isinstance(v, kind) or (isinstance(v, bool) and kind is not bool):
            raise BatchError(f"{where}: option '{k}' has the wrong type ({type(v).__name__})")
    if "extern" in options:
        options = dict(options, extern=[x if os.path.isabs(x) else os.path.join(folder, x) for x in options["extern"]])
    timeout = _number(e.get("timeout"), where, "timeout")
    memory = _number(e.get("memory"), where, "memory")
    portfolio = e.get("portfolio", [])
    if isinstance(portfolio, str):
        portfolio = [p for p in portfolio.split(",") if p]
    if not isinstance(portfolio, list) or not all(isinstance(p, str) for p in portfolio):
        raise BatchError(f"{where}: 'portfolio' must be a list of solver or strategy names")
    solver = e.get("solver")
    if solver is not None and not isinstance(solver, str):
        raise BatchError(f"{where}: 'solver' must be a name")
    ident = e.get("id")
    if ident is None:
        rel = os.path.relpath(full, folder)
        name = os.path.basename(domain) if rel.startswith("..") or os.path.isabs(domain) else rel
        ident = os.path.splitext(name)[0] + (f"#{query}" if query is not None else "")
    return Job(str(ident), os.path.abspath(full), query, scene and os.path.abspath(scene), solver, options,
               timeout, None if memory is None else int(memory), bool(e.get("plans", False)), portfolio)


def _number(v: object, where: str, what: str) -> float | None:
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
        raise BatchError(f"{where}: '{what}' must be a number > 0 ({'seconds' if what == 'timeout' else 'MB'})")
    return float(v)


def _unique(jobs: list[Job], path: str) -> list[Job]:
    seen: set[str] = set()
    for j in jobs:
        if j.id in seen:
            raise BatchError(f"{path}: two jobs have the id '{j.id}' (ids name results: give each an 'id')")
        seen.add(j.id)
    return jobs
