"""The results of a batch: one JSON line per job, appended and synced as each job ends, so a
batch that is interrupted or crashes loses nothing it finished and resumes from the file;
and the CSV summary, written from the file (the last valid record of each job wins).  The
file is locked while a batch writes it: two batches on one results file would run every job
twice.
"""
from __future__ import annotations

import csv
import json
import os

from cplus.files import open_output

__all__ = ["ResultsFile", "ResultsBusy", "write_csv", "FAILED", "PLAN_STATUSES", "STATUSES", "CSV_COLUMNS"]

FAILED = ("error", "timeout", "memory", "lost")
"""A job's statuses that are not a planner's answer."""

CSV_COLUMNS = ("id", "status", "maxstep", "queries", "wall_s", "cpu_s", "load_s", "ground_s", "encode_s", "solve_s",
               "horizons", "variables", "clauses", "solver", "winner", "attempts", "worker", "domain", "query", "error")


PLAN_STATUSES = ("found", "no_plan", "no_plan_proved", "horizon_limit", "invariant_wrong", "no_safe_plan",
                 "gave_up", "unsafe")
"""A query's statuses, best first: a job's status is its queries' worst.  ``no_plan_proved``
and ``invariant_wrong`` are a ``maxstep :: any`` query's proof (``cplus plan``'s exit codes 10
and 11)."""

STATUSES = (*PLAN_STATUSES, *FAILED)
"""Every status a ``cplus.batch/1`` record may have: a planner's answer, or :data:`FAILED`."""


class ResultsBusy(OSError):
    """Another process (another batch) holds the results file; ``holder`` says which."""

    def __init__(self, path: str, holder: str | None) -> None:
        super().__init__(f"{path}: another batch is writing it" + (f" ({holder})" if holder else ""))
        self.path = path
        self.holder = holder


class ResultsFile:
    """A ``cplus.batch/1`` JSON-lines file: :meth:`open` takes it for this batch (an exclusive
    lock: a second batch on the same file is refused, naming the first), :meth:`records`
    reads what is there, and :meth:`append` adds a record durably (flushed and ``fsync``-ed
    before it returns).

    A line that is no record of the schema (cut short by a crash, edited by hand: a status
    that is not one of :data:`STATUSES`, times that are not numbers) is left out and named in
    :attr:`problems` with its line number; its job is not done and runs again."""

    def __init__(self, path: str) -> None:
        self.path = path
        self._fh = None
        self.problems: list[str] = []

    def open(self, fresh: bool = False) -> None:
        """Open (create) the file for this batch and lock it; ``fresh``: empty it first.

        Raises:
            ResultsBusy: another process holds the lock.
            OSError: the file cannot be opened.
        """
        import fcntl
        fh = open(self.path, "a+", encoding="utf-8", errors="replace")
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _lock_holder(fh.fileno())
            fh.close()
            raise ResultsBusy(self.path, holder) from None
        self._fh = fh                                  # type: ignore[assignment]
        if fresh:
            fh.truncate(0)
        elif fh.tell() > 0:
            fh.seek(fh.tell() - 1)
            if fh.read(1) != "\n":           # a line cut short: the next record starts on its own
                fh.write("\n")

    def records(self) -> dict[str, dict]:
        """Every job's last valid record, by id (the file open, or not yet: read as it is)."""
        out: dict[str, dict] = {}
        self.problems = []
        if self._fh is not None:
            fh = self._fh
            fh.seek(0)
            lines = fh.read().splitlines()
        elif os.path.isfile(self.path):
            with open(self.path, encoding="utf-8", errors="replace") as f:
                lines = f.read().splitlines()
        else:
            return out
        bad: list[tuple[int, str | None, str]] = []      # line, its job's id if it has one, why
        last: dict[str, int] = {}
        for n, line in enumerate(lines, 1):
            if not line.strip():
                continue
            why = _not_a_record(line)
            if isinstance(why, str):
                bad.append((n, _id_of(line), why))
                continue
            out[why["id"]] = why
            last[why["id"]] = n
        # a bad line that a later record of its job replaces is history, not a problem
        self.problems = [f"{self.path}:{n}: {why}" for n, ident, why in bad if ident is None or last.get(ident, 0) < n]
        return out

    def append(self, record: dict) -> None:
        fh = self._fh
        assert fh is not None, "open() first"
        fh.write(json.dumps(record, separators=(",", ":"), default=str) + "\n")
        fh.flush()
        os.fsync(fh.fileno())

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()                           # the lock goes with it
            self._fh = None


def _not_a_record(line: str) -> dict | str:
    """The record a line holds, or why it holds none (one phrase)."""
    try:
        rec = json.loads(line)
    except ValueError:
        return "not a record (not JSON: a line cut short?); ignored"
    if not isinstance(rec, dict):
        return "not a record (not a JSON object); ignored"
    ident = rec.get("id")
    if not isinstance(ident, str) or not ident:
        return "not a record (no 'id'); ignored"
    status = rec.get("status")
    if status not in STATUSES:
        return f"job {ident!r}: status {json.dumps(status)[:40]} is not one of {', '.join(STATUSES)}; it runs again"
    times, stats, results = rec.get("times", {}), rec.get("stats", {}), rec.get("results", [])
    if not isinstance(times, dict) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                              for v in times.values()):
        return f"job {ident!r}: 'times' are not numbers of seconds; it runs again"
    if not isinstance(stats, dict) or not isinstance(results, list) or not all(
            isinstance(r, dict) and isinstance(r.get("query"), str) and isinstance(r.get("status"), str)
            for r in results):
        return f"job {ident!r}: 'stats' or 'results' are not those of a record; it runs again"
    maxstep = rec.get("maxstep")
    if maxstep is not None and (not isinstance(maxstep, int) or isinstance(maxstep, bool)):
        return f"job {ident!r}: 'maxstep' is not a number; it runs again"
    if not isinstance(rec.get("portfolio", {}), dict) or not isinstance(rec.get("error") or "", str):
        return f"job {ident!r}: 'portfolio' or 'error' are not those of a record; it runs again"
    return rec


def _id_of(line: str) -> str | None:
    try:
        rec = json.loads(line)
    except ValueError:
        return None
    ident = rec.get("id") if isinstance(rec, dict) else None
    return ident if isinstance(ident, str) else None


def _lock_holder(fd: int) -> str | None:
    """Which process holds the lock of the file open at ``fd`` (Linux's ``/proc/locks``):
    ``pid 123: cplus batch jobs.toml``, or None when it cannot be told."""
    st = os.fstat(fd)
    want = f"{os.major(st.st_dev):02x}:{os.minor(st.st_dev):02x}:{st.st_ino}"
    try:
        with open("/proc/locks", encoding="ascii", errors="replace") as fh:
            lines = fh.read().splitlines()
    except OSError:
        return None
    for line in lines:
        words = line.split()
        if "->" in words or len(words) < 6:
            continue
        pid, inode = words[4], words[5]
        if inode == want and pid.isdigit() and int(pid) != os.getpid():
            try:
                with open(f"/proc/{pid}/cmdline", "rb") as f:
                    command = " ".join(a.decode("utf-8", "replace") for a in f.read().split(b"\0") if a)
            except OSError:
                command = ""
            command = " ".join(command.split())[:120]         # one line
            return f"pid {pid}" + (f": {command}" if command else "")
    return None


def write_csv(path: str, records: list[dict]) -> None:
    """One row per job (:data:`CSV_COLUMNS`), in the order given (:mod:`cplus.files`'s rule:
    a regular file replaced atomically, a device or a FIFO written through)."""
    with open_output(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CSV_COLUMNS)
        for r in records:
            times, stats = r.get("times") or {}, r.get("stats") or {}
            results = r.get("results") or []
            w.writerow([r.get("id"), r.get("status"), "" if r.get("maxstep") is None else r["maxstep"],
                        ";".join(f"{q['query']}={q['status']}" for q in results),
                        *(times.get(k, "") for k in ("wall_s", "cpu_s", "load_s", "ground_s", "encode_s", "solve_s")),
                        stats.get("horizons", ""), stats.get("variables", ""), stats.get("clauses", ""),
                        r.get("solver") or "", (r.get("portfolio") or {}).get("winner") or "", r.get("attempts", ""),
                        r.get("worker", ""), r.get("domain", ""), r.get("query") or "",
                        (r.get("error") or "").replace("\n", " ")])
