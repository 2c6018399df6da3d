"""Many planning jobs at once: ``cplus batch`` on a local process pool or on Ray.

* :func:`read_jobs`, :class:`Job`, :class:`BatchError` — job files (:mod:`.jobs`);
* :func:`run_local`, :func:`run_ray` — the engines (:mod:`.engine`): the pool or Ray places the
  jobs, nothing here schedules;
* :class:`ResultsFile`, :func:`write_csv` — results streamed as JSON lines, resumable, and the
  CSV summary (:mod:`.results`);
* :class:`Deadline`, :class:`MemoryLimit` — a job's limits, enforced in its process
  (:mod:`.limits`); :class:`Progress` — the bar on stderr (:mod:`.progress`).

What a job *does* is given to the engines as a function (``cplus.cli.batch_job.run_job``, the
command's: a robot task's refinement belongs to the robot stack, which this package may not
import), so Ray ships it by reference and the pool forks it.
"""
from __future__ import annotations

from cplus.batch.engine import RAY_MISSING, lost_record, run_local, run_ray
from cplus.batch.jobs import BatchError, Job, read_jobs
from cplus.batch.limits import Deadline, MemoryLimit
from cplus.batch.progress import Progress
from cplus.batch.results import FAILED, ResultsFile, write_csv

__all__ = ["FAILED", "RAY_MISSING", "BatchError", "Deadline", "Job", "MemoryLimit", "Progress", "ResultsFile",
           "lost_record", "read_jobs", "run_local", "run_ray", "write_csv"]
