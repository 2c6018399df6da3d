"""The results of a batch: one JSON line per job, appended and synced as each job ends, so a
batch that is interrupted or crashes loses nothing it finished and resumes from the file;
and the CSV summary, written from the file (the last record of each job wins).
"""
from __future__ import annotations

import csv
import json
import os

__all__ = ["ResultsFile", "write_csv", "FAILED", "CSV_COLUMNS"]

FAILED = ("error", "timeout", "memory", "lost")
"""A job's statuses that are not a planner's answer."""

CSV_COLUMNS = ("id", "status", "maxstep", "queries", "wall_s", "cpu_s", "load_s", "ground_s", "encode_s", "solve_s",
               "horizons", "variables", "clauses", "solver", "winner", "attempts", "worker", "domain", "query", "error")


class ResultsFile:
    """A ``cplus.batch/1`` JSON-lines file: :meth:`records` reads what is there (a line cut
    short by a crash is skipped, and the next record starts on a line of its own), and
    :meth:`append` adds a record durably (flushed and ``fsync``-ed before it returns)."""

    def __init__(self, path: str) -> None:
        self.path = path
        self._fh = None

    def records(self) -> dict[str, dict]:
        """Every job's last record, by id."""
        out: dict[str, dict] = {}
        if not os.path.isfile(self.path):
            return out
        with open(self.path, encoding="utf-8", errors="replace") as fh:
            for line in fh:
                try:
                    rec = json.loads(line)
                except json.JSONDecodeError:
                    continue
                if isinstance(rec, dict) and isinstance(rec.get("id"), str) and rec.get("status"):
                    out[rec["id"]] = rec
        return out

    def open(self, fresh: bool = False) -> None:
        folder = os.path.dirname(os.path.abspath(self.path))
        os.makedirs(folder, exist_ok=True)
        self._fh = open(self.path, "w" if fresh else "a+", encoding="utf-8")   # type: ignore[assignment]
        fh = self._fh
        if not fresh and fh.tell() > 0:       # type: ignore[attr-defined]
            fh.seek(fh.tell() - 1)            # type: ignore[attr-defined]
            if fh.read(1) != "\n":            # type: ignore[attr-defined]
                fh.write("\n")                # type: ignore[attr-defined]

    def append(self, record: dict) -> None:
        fh = self._fh
        assert fh is not None, "open() first"
        fh.write(json.dumps(record, separators=(",", ":"), default=str) + "\n")
        fh.flush()
        os.fsync(fh.fileno())

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None


def write_csv(path: str, records: list[dict]) -> None:
    """One row per job (:data:`CSV_COLUMNS`), in the order given."""
    tmp = path + ".tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as fh:
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
    os.replace(tmp, path)
