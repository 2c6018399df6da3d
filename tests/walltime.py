"""Wall time for the tests that need it: seconds on an idle machine, times one scale factor.

Most tests wait on events or run on simulated time and need no wall time at all. What is left
(a bound on how long a subprocess may take before the test gives up on it, a ``cplus brick``
process's link timeouts, the time a client waits for a server to come up) is written as the
seconds an idle two-core machine needs with a wide margin, and passed through :func:`wall`.

The factor is ``CPLUS_TEST_TIME_SCALE`` when it is set. Otherwise ``tests/conftest.py`` derives
it once, when the run starts (:func:`machine_scale`), and exports it, so that pytest-xdist's
workers and the processes the tests start use the same value: the machine's load per core,
the larger of the one-minute load average and the processes runnable right now (the average
lags a load that has just started by a minute), never below 1. A test's processes get about
``cores / load`` of a core each on a loaded machine, so what takes ``s`` seconds idle takes
about ``s * load / cores``. The pytest-timeout limit of every test is scaled the same way.
"""
from __future__ import annotations

import os

ENV = "CPLUS_TEST_TIME_SCALE"


def machine_scale() -> float:
    """The load per core now, at least 1, to one decimal (see the module docstring)."""
    cores = os.cpu_count() or 1
    load = os.getloadavg()[0]
    try:
        with open("/proc/loadavg", encoding="ascii") as f:
            running = int(f.read().split()[3].split("/")[0]) - 1   # not counting the reader
        load = max(load, float(running))
    except (OSError, ValueError, IndexError):
        pass
    return max(1.0, round(load / cores, 1))


def scale() -> float:
    """The factor in force: ``CPLUS_TEST_TIME_SCALE``, else the machine's (computed now)."""
    text = os.environ.get(ENV)
    if text is None:
        return machine_scale()
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{ENV} must be a number, got {text!r}") from None
    if not value >= 1.0:
        raise ValueError(f"{ENV} must be at least 1, got {text!r}")
    return value


def wall(seconds: float) -> float:
    """``seconds`` of wall time on an idle machine, as many on this one."""
    return seconds * scale()


ORDERLY_STOP = {"CPLUS_STOP_GRACE": "600"}
"""The environment of a command whose orderly stop (SIGINT, SIGTERM) a test checks: without it
the command's watchdog forces a stop that takes over 1.2 s (``serve``) or 1.5 s (``run``,
``online``, ``execute``), which a loaded machine's orderly stop can (a ROS server's exit 0
became 143 in a run of the suite at load 12). Tests of the watchdog itself set their own."""
