"""Running a batch's jobs: on a local process pool (:mod:`concurrent.futures`) or on Ray.

Neither engine schedules anything itself: the pool or Ray places each job on a free worker.
The driver only keeps as many jobs submitted as there are workers (Ray's "limit pending
tasks" pattern; on the pool the same), so that every submitted job is running: its start
time is known (the progress bar's slowest job, the backstop of its time limit) and a lost
worker names the jobs it had.

* time and memory limits are enforced inside the job (:mod:`cplus.batch.limits`); as a
  backstop a job still running a grace period past its limit is killed (Ray: ``ray.cancel(
  force=True)``; the pool: its process);
* a worker lost (killed, out of memory, crashed) fails the job it ran, which is submitted
  again, up to ``retries`` times, then recorded as ``lost``; on Ray ``max_retries`` does it.
  On the pool, :mod:`concurrent.futures` breaks the whole pool when one process dies and does
  not say which: the pool is rebuilt, and the jobs that were running then run again one at a
  time, uncharged, so that the one whose process dies alone is the one charged;
* a portfolio job runs its variants at once: on Ray as one task each, the first with an
  answer wins and the others are cancelled (``force=True`` kills them); on the pool inside the
  job's process (:func:`cplus.cli.batch_job.race`), so that the pool's workers are the
  unit of work either way.

Ctrl-C (and SIGTERM, which the command turns into the same): the jobs in flight are
cancelled (their processes ended, and the pool's fork server and resource tracker with
them), nothing more is recorded, and the batch resumes from its results file.
"""
from __future__ import annotations

import os
import signal
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from cplus.batch.jobs import BatchError, Job
from cplus.batch.limits import GRACE_S
from cplus.batch.progress import Progress
from cplus.batch.results import FAILED

__all__ = ["run_local", "run_ray", "lost_record", "unreachable", "RAY_MISSING"]

RAY_MISSING = ("--ray needs Ray, an optional extra: pip install 'cplus[ray]' (from a checkout: pip install '.[ray]'; "
               "or pip install 'ray>=2.40')")

Sink = Callable[[dict], None]


def no_local_instance(exc: BaseException) -> str:
    """One line for a local Ray instance that did not start (on a machine so loaded that its
    raylet missed Ray's fixed 30 s, say)."""
    reason = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
    return (f"--ray: a local Ray instance did not start: {reason} (nothing was run; without --ray the jobs run "
            "in local processes)")


def unreachable(address: str, exc: BaseException) -> str:
    """One line for a cluster that ``ray.init`` could not join: Ray's own reason, or the refused
    token its causes name deep in a nested traceback's text, with the two ways Ray reads one."""
    lines: list[str] = []
    seen: BaseException | None = exc
    while seen is not None and len(lines) < 200:
        lines += [x.strip() for x in str(seen).splitlines() if x.strip()]
        seen = seen.__cause__ or seen.__context__
    auth = next((x for x in lines if "authenticat" in x.lower() or "auth token" in x.lower()), None)
    why = auth.split(". ")[0] if auth else (lines[0] if lines else type(exc).__name__)
    line = f"--ray {address}: cannot join the Ray cluster ({why.rstrip('.')})"
    if auth:
        line += ("; a cluster with token authentication needs RAY_AUTH_MODE=token and its token "
                 "(RAY_AUTH_TOKEN, or the file ~/.ray/auth_token)")
    return line


def lost_record(job: Job, attempts: int, why: str, status: str = "lost") -> dict:
    """The record of a job whose worker never returned."""
    return {"format": "cplus.batch/1", "id": job.id, "domain": job.domain, "query": job.query, "scene": job.scene,
            "solver": job.solver, "options": job.options, "status": status, "maxstep": None, "results": [],
            "times": {}, "stats": {}, "error": why, "worker": None, "attempts": attempts,
            "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z")}


def _over_time(job: Job, started: float) -> bool:
    return job.timeout is not None and time.monotonic() - started >= job.timeout


def _deliver(record: dict, sink: Sink, progress: Progress) -> None:
    sink(record)
    progress.finished(record, record["status"] in FAILED)


# ------------------------------------------------------------------------------------- the pool


def run_local(jobs: list[Job], fn: Callable, workers: int, retries: int, sink: Sink, progress: Progress,
              initializer: Callable | None = None) -> None:
    """The jobs on a pool of ``workers`` processes.

    The processes come from a fork server (``forkserver``): each starts from a small clean
    process with the planner already imported, not from a copy of the caller, whose heap
    (free memory included) would let a job allocate beyond its memory limit unnoticed."""
    import concurrent.futures as cf
    import multiprocessing
    from concurrent.futures.process import BrokenProcessPool
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload(["cplus.api", "cplus.cli.batch_job"])
    queue = deque(jobs)
    suspects: deque[Job] = deque()      # running when the pool broke beside others: run alone next
    attempts = {j.id: 0 for j in jobs}
    while queue or suspects:
        pool = cf.ProcessPoolExecutor(workers, mp_context=ctx, initializer=_quiet_worker,
                                      initargs=(initializer,))
        running: dict[cf.Future, tuple[Job, float]] = {}
        broken = False
        try:
            while queue or suspects or running:
                while not broken and ((suspects and not running) or (queue and not suspects and
                                                                        len(running) < workers)):
                    job = suspects.popleft() if suspects else queue.popleft()
                    attempts[job.id] += 1
                    running[pool.submit(fn, job.to_dict(), attempts[job.id])] = (job, time.monotonic())
                    progress.start(job.id)
                done, _ = cf.wait(list(running), timeout=0.25, return_when=cf.FIRST_COMPLETED)
                for f in done:
                    job, started = running.pop(f)
                    try:
                        record = f.result()
                    except BrokenProcessPool:
                        broken = True
                        running[f] = (job, started)      # dealt with below, with the others
                        continue
                    except Exception as exc:     # a bug in the job's code: recorded, the batch goes on
                        record = lost_record(job, attempts[job.id], f"{type(exc).__name__}: {exc}", "error")
                    _deliver(record, sink, progress)
                for job, started in list(running.values()):     # the backstop of the time limit
                    if job.timeout is not None and time.monotonic() - started > job.timeout + GRACE_S + 5:
                        _kill_pool(pool)
                        broken = True
                        break
                if broken:
                    break
                progress.tick()
        except KeyboardInterrupt:
            _kill_pool(pool)
            # the fork server before the shutdown, which joins the thread feeding the workers'
            # call queue (a batch outlived SIGTERM by a minute in the suite; a fork server still
            # holding that pipe was the suspect); the resource tracker after it, since the
            # shutdown releases what the tracker tracks
            _stop_helper("forkserver")
            pool.shutdown(wait=True, cancel_futures=True)
            _stop_helper("resource_tracker")
            raise
        finally:
            pool.shutdown(wait=not broken, cancel_futures=True)
        if broken:
            _kill_pool(pool)
            if len(running) > 1:
                # the pool does not say whose process died: each runs alone next, uncharged
                for job, _ in running.values():
                    attempts[job.id] -= 1
                    progress.running.pop(job.id, None)
                    suspects.append(job)
                continue
            for job, started in running.values():
                if _over_time(job, started):
                    _deliver(lost_record(job, attempts[job.id], f"over its time limit of {job.timeout:g} s "
                                         "(its process was killed)", "timeout"), sink, progress)
                elif attempts[job.id] > retries:
                    _deliver(lost_record(job, attempts[job.id], f"its worker process was lost {attempts[job.id]} "
                                         "times"), sink, progress)
                else:
                    progress.running.pop(job.id, None)
                    suspects.appendleft(job)


def _quiet_worker(initializer: Callable | None) -> None:
    """A pool process: Ctrl-C is the driver's to handle (it ends the pool), so an idle worker
    ignores it; a job's deadline installs its own handler while the job runs."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if initializer is not None:
        initializer()


def _stop_helper(name: str) -> None:
    """End a process :mod:`multiprocessing` started for the pool besides its workers, its
    ``forkserver`` or its ``resource_tracker`` (it would otherwise outlive an interrupted batch
    until it notices, or not at all)."""
    from multiprocessing import forkserver, resource_tracker
    helpers: dict[str, Any] = {"forkserver": forkserver._forkserver, "resource_tracker": resource_tracker._resource_tracker}
    helper = helpers[name]
    try:
        helper._stop()
    except (OSError, AttributeError, ChildProcessError):
        pass


def _kill_pool(pool) -> None:
    """End the pool's processes now (``concurrent.futures`` has no way to stop a running
    call; its ``_processes`` are the pool's own ``multiprocessing`` processes)."""
    for p in list((getattr(pool, "_processes", None) or {}).values()):
        try:
            if p.is_alive():
                p.kill()
        except (OSError, ValueError, AttributeError):
            pass


# ------------------------------------------------------------------------------------- Ray


def run_ray(jobs: list[Job], fn: Callable, workers: int | None, address: str | None, retries: int, sink: Sink,
            progress: Progress, variant: Callable[[dict, str], dict], definite: tuple[str, ...]) -> None:
    """The jobs as Ray tasks: on a local Ray instance started here (``address`` None, with
    ``workers`` CPUs) and shut down at the end, or on the cluster at ``address``."""
    try:
        import ray
    except ImportError:
        raise BatchError(RAY_MISSING) from None
    if not jobs:                 # nothing to run: no instance started, no cluster joined
        return
    # a local instance's workers run this checkout (its PYTHONPATH); a cluster's nodes have cplus installed
    names = ("PYTHONPATH", "OPENBLAS_NUM_THREADS") if address is None else ("OPENBLAS_NUM_THREADS",)
    env = {"env_vars": {k: os.environ[k] for k in names if k in os.environ}}
    env["env_vars"].setdefault("OPENBLAS_NUM_THREADS", "1")
    kwargs: dict[str, Any] = dict(include_dashboard=False, logging_level="ERROR", log_to_driver=False, runtime_env=env)
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")     # no report home from a batch
    started_here = address is None
    if started_here:
        # on the loopback interface: a machine without a network (or as root in a container)
        # starts it as well, and nothing listens beyond this host. address="local": a new
        # instance even where RAY_ADDRESS is set or a `ray start` cluster runs on this host
        # (ray.init() without an address would join that one instead)
        try:
            ray.init(address="local", num_cpus=workers or os.cpu_count() or 1, _node_ip_address="127.0.0.1",
                     **kwargs)
        except Exception as exc:    # Ray raises a bare Exception when its raylet is not up in 30 s
            ray.shutdown()           # what did start (GCS, raylet) is stopped
            raise BatchError(no_local_instance(exc)) from None
    else:
        try:
            ray.init(address=address, **kwargs)
        except (ConnectionError, RuntimeError, ValueError, ray.exceptions.RayError) as exc:
            raise BatchError(unreachable(str(address), exc)) from None
    try:
        _ray_loop(ray, jobs, fn, retries, sink, progress, variant, definite)
    finally:
        ray.shutdown()


def _ray_loop(ray, jobs: list[Job], fn: Callable, retries: int, sink: Sink, progress: Progress,
              variant: Callable[[dict, str], dict], definite: tuple[str, ...]) -> None:
    cpus = max(1, int(ray.cluster_resources().get("CPU", 1)))
    task = ray.remote(fn)
    queue = deque(jobs)
    flight: dict = {}                   # ref -> (job, variant name or None, started)
    groups: dict[str, list] = {}        # job id -> its refs still running (a portfolio's variants)
    finished: dict[str, dict] = {}      # portfolio variants' records so far
    used = 0
    try:
        while queue or flight:
            while queue and (used < cpus or not flight):
                job = queue.popleft()
                opts = {"num_cpus": 1, "max_retries": retries}
                if job.memory:
                    opts["memory"] = int(job.memory) << 20
                spec = job.to_dict()
                names: list[str | None] = list(job.portfolio) or [None]
                refs = []
                for name in names:
                    one = variant(spec, name) if name else spec
                    cpu = max(1, int(one["options"].get("jobs", 1))) if isinstance(one["options"].get("jobs"), int) else 1
                    ref = task.options(**dict(opts, num_cpus=min(cpu, cpus))).remote(one, 1)
                    flight[ref] = (job, name, time.monotonic())
                    refs.append(ref)
                    used += 1
                groups[job.id] = refs
                progress.start(job.id)
            ready, _ = ray.wait(list(flight), num_returns=1, timeout=0.25)
            for ref in ready:
                job, name, started = flight.pop(ref)
                used -= 1
                if ref not in groups.get(job.id, []):
                    continue          # a cancelled loser
                groups[job.id].remove(ref)
                try:
                    record = ray.get(ref)
                except (ray.exceptions.WorkerCrashedError, ray.exceptions.NodeDiedError,
                        ray.exceptions.OutOfMemoryError, ray.exceptions.RayTaskError,
                        ray.exceptions.RaySystemError, ray.exceptions.TaskCancelledError) as exc:
                    # a cancelled task here is one the time limit's backstop below cancelled (a
                    # portfolio's losers left their group before they were cancelled): recorded
                    # as over its time, never dropped
                    status = "timeout" if _over_time(job, started) else "lost"
                    if isinstance(exc, ray.exceptions.OutOfMemoryError):
                        status = "memory"
                    cancelled = isinstance(exc, ray.exceptions.TaskCancelledError)    # never retried
                    record = lost_record(job, 1 if cancelled else retries + 1,
                                         f"{type(exc).__name__}: {_last_line(exc)}", status)
                if name is not None:
                    finished.setdefault(job.id, {})[name] = record
                    if record["status"] not in definite and groups[job.id]:
                        continue      # wait for the other variants
                    for loser in groups.pop(job.id):
                        ray.cancel(loser, force=True)
                    record = dict(record, id=job.id, solver=job.solver, options=job.options,
                                  portfolio={"winner": name if record["status"] in definite else None,
                                             "variants": job.portfolio,
                                             "finished": {n: r["status"] for n, r in finished.pop(job.id).items()}})
                else:
                    groups.pop(job.id, None)
                _deliver(record, sink, progress)
            for ref, (job, _, started) in list(flight.items()):     # the backstop of the time limit
                if job.timeout is not None and time.monotonic() - started > job.timeout + GRACE_S + 5:
                    ray.cancel(ref, force=True)
            progress.tick()
    except KeyboardInterrupt:
        for ref in flight:
            ray.cancel(ref, force=True)
        raise


def _last_line(exc: BaseException) -> str:
    """The line of a Ray error that says what happened (its first names the task)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return lines[-1] if lines else type(exc).__name__
