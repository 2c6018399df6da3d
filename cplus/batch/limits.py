"""A job's time and memory limits, enforced inside the process that runs it.

**Time.**  pysat's solvers hold the interpreter lock while they search, so no Python thread
or signal handler runs until a solve returns; but they do catch SIGINT in their C code (and
return at once).  So the deadline is a POSIX timer of the kernel (``timer_create`` through
ctypes) that sends SIGINT to the process: a solve stops at once, Python code (grounding,
encoding) stops at its next bytecode, and :class:`Deadline` tells its expiry from a Ctrl-C by
the clock.  A second timer, a grace period later, sends SIGKILL, for code that would ignore
the first; the process is then lost, and the engine reports the job as over its time.

**Memory.**  ``RLIMIT_AS`` is set to the address space the process already has plus the job's
limit (a Ray worker maps gigabytes before any job), and put back after the job: an
allocation beyond it fails (``MemoryError``), and the planner's own size checks, which read
the limit (:func:`cplus.limits.memory_budget`), refuse a horizon that cannot fit before
building it.
"""
from __future__ import annotations

import ctypes
import os
import signal
import time

__all__ = ["Deadline", "MemoryLimit", "GRACE_S"]

GRACE_S = 10.0
"""After the deadline's SIGINT, how long before SIGKILL (seconds): a solve returns within
milliseconds of SIGINT, so this only catches code that ignores it."""

_CLOCK_MONOTONIC = 1
_SIGEV_SIGNAL = 0


class _SigEvent(ctypes.Structure):
    _fields_ = [("value", ctypes.c_void_p), ("signo", ctypes.c_int), ("notify", ctypes.c_int),
                ("pad", ctypes.c_int * 12)]


class _TimeSpec(ctypes.Structure):
    _fields_ = [("sec", ctypes.c_long), ("nsec", ctypes.c_long)]


class _ITimerSpec(ctypes.Structure):
    _fields_ = [("interval", _TimeSpec), ("value", _TimeSpec)]


def _libc():
    try:
        return ctypes.CDLL(None, use_errno=True)
    except OSError:   # pragma: no cover
        return None


class _Timer:
    """One kernel timer that sends ``signo`` to this process once, ``seconds`` from now."""

    def __init__(self, seconds: float, signo: int) -> None:
        self.libc = _libc()
        self.id = ctypes.c_void_p()
        self.armed = False
        if self.libc is None or not hasattr(self.libc, "timer_create"):
            return
        ev = _SigEvent(None, signo, _SIGEV_SIGNAL)
        if self.libc.timer_create(_CLOCK_MONOTONIC, ctypes.byref(ev), ctypes.byref(self.id)) != 0:
            return
        whole = int(seconds)
        spec = _ITimerSpec(_TimeSpec(0, 0), _TimeSpec(whole, max(1, int((seconds - whole) * 1e9))))
        self.armed = self.libc.timer_settime(self.id, 0, ctypes.byref(spec), None) == 0

    def cancel(self) -> None:
        if self.armed:
            self.libc.timer_delete(self.id)
            self.armed = False


class Deadline:
    """``with Deadline(seconds) as d:`` — SIGINT to this process after ``seconds`` (SIGKILL
    :data:`GRACE_S` later); ``d.expired`` tells, after a ``KeyboardInterrupt``, whether it was
    the deadline.  ``None``: no limit.  Only in the main thread (SIGINT goes to it)."""

    def __init__(self, seconds: float | None, grace: float = GRACE_S) -> None:
        self.seconds = seconds
        self.grace = grace
        self.start = 0.0
        self._timers: list[_Timer] = []
        self._old: object = None

    def __enter__(self) -> Deadline:
        self.start = time.monotonic()
        if self.seconds is not None:
            # Python's own SIGINT handler: a pool worker may have set SIGINT to be ignored
            self._old = signal.signal(signal.SIGINT, signal.default_int_handler)
            _unblock()
            self._timers = [_Timer(self.seconds, signal.SIGINT), _Timer(self.seconds + self.grace, signal.SIGKILL)]
        return self

    @property
    def expired(self) -> bool:
        return self.seconds is not None and time.monotonic() - self.start >= self.seconds * 0.999

    def __exit__(self, *exc) -> None:
        for t in self._timers:
            t.cancel()
        _unblock()
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)   # type: ignore[arg-type]


def _unblock() -> None:
    """Unblock SIGINT: a solver interrupted by it leaves its C handler with ``longjmp``, which
    keeps the signal blocked, and the next deadline (or Ctrl-C) would never arrive."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _address_space() -> int:
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except OSError:   # pragma: no cover - no /proc
        pass
    return 0


class MemoryLimit:
    """``with MemoryLimit(mb):`` — at most ``mb`` more megabytes of address space (None: no
    limit); the previous limit is put back afterwards (pool workers run many jobs)."""

    def __init__(self, mb: int | None) -> None:
        self.mb = mb
        self._old: tuple[int, int] | None = None

    def __enter__(self) -> MemoryLimit:
        if self.mb is not None:
            import resource
            self._old = resource.getrlimit(resource.RLIMIT_AS)
            want = _address_space() + self.mb * (1 << 20)
            hard = self._old[1]
            if hard != resource.RLIM_INFINITY:
                want = min(want, hard)
            resource.setrlimit(resource.RLIMIT_AS, (want, hard))
        return self

    def __exit__(self, *exc) -> None:
        if self._old is not None:
            import resource
            resource.setrlimit(resource.RLIMIT_AS, self._old)


def pid_host() -> str:
    """``host:pid`` of this process, for the results (which worker ran a job)."""
    return f"{os.uname().nodename}:{os.getpid()}"
