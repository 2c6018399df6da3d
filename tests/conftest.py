"""Shared test settings: the conformance corpus, Hypothesis, and the `slow`/`hardware` markers.

* Hypothesis runs without its per-example deadline and without the "too slow" health check
  (both are timed assertions: they fail on a loaded machine, not on a wrong answer); example
  counts bound the run time.
* ``slow`` marks tests that must run in real time (a process on a pseudo-terminal, the
  whole job end to end). They run by default, so ``python -m pytest`` is the full suite;
  ``-m "not slow"`` leaves them out for a quick local loop.
* ``hardware`` marks tests that need a real NXT brick. They run only with
  ``--run-nxt PORT`` (``/dev/rfcomm0`` for Bluetooth, the brick's USB tty, ...) and are
  skipped otherwise; the port reaches them through the ``nxt_port`` fixture.
* Wall time: a test that needs some (a bound on a subprocess, a ``cplus brick`` process's
  link timeouts) asks :func:`walltime.wall` for it, seconds on an idle machine times one
  factor, ``CPLUS_TEST_TIME_SCALE``: when it is not set, it is the machine's load per core
  when the run starts (at least 1), exported here so that pytest-xdist's workers and the
  tests' processes share it. Every test's pytest-timeout limit is scaled by it too, and the
  header of the run says what it is.
* SIGINT: a run started in the background has it ignored, and would hand that on to the
  commands the tests interrupt; it is handled again here (see ``pytest_configure``).
"""
from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest
import walltime
from hypothesis import HealthCheck, settings

ROOT = Path(__file__).resolve().parent.parent
CORPUS = Path(os.environ.get("CPLUS_CORPUS", ROOT / "tests" / "corpus"))

settings.register_profile("cplus", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("cplus")


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--run-nxt", metavar="PORT", default=None,
                     help="run the tests marked 'hardware' against a real NXT brick on this serial "
                          "port (e.g. /dev/rfcomm0); without it they are skipped")


def pytest_configure(config: pytest.Config) -> None:
    # A run started in the background (`pytest ... &`, `nohup`) has SIGINT ignored, as the
    # shell does for background jobs, and an ignored signal stays ignored across fork and exec:
    # every command the tests start would ignore the Ctrl-C a test sends it, and that test
    # would wait for it until its time limit. Handled here, the children start with SIGINT at
    # its default (a handler does not survive exec); a background run gets no Ctrl-C anyway.
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if walltime.ENV not in os.environ:   # before xdist starts its workers: they inherit it
        os.environ[walltime.ENV] = str(walltime.machine_scale())
    try:
        walltime.scale()                  # a malformed value fails the run here, once
    except ValueError as exc:
        raise pytest.UsageError(str(exc)) from None


def pytest_report_header(config: pytest.Config) -> str:
    one, _, _ = os.getloadavg()
    return (f"wall-time scale {walltime.scale():g} ({walltime.ENV}; load average {one:.1f} on "
            f"{os.cpu_count()} cores)")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    _time_limits(config, items)
    if config.getoption("--run-nxt"):
        return
    skip = pytest.mark.skip(reason="needs a real NXT brick: give its port with --run-nxt PORT")
    for item in items:
        if "hardware" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def nxt_port(request: pytest.FixtureRequest) -> str:
    """The serial port of the real brick given with ``--run-nxt``."""
    port = request.config.getoption("--run-nxt")
    if not port:
        pytest.skip("needs a real NXT brick: give its port with --run-nxt PORT")
    return port


@pytest.fixture
def corpus() -> Path:
    if not (CORPUS / "manifest.json").is_file():
        pytest.fail(f"the conformance corpus is missing at {CORPUS} (set CPLUS_CORPUS)")
    return CORPUS


def _time_limits(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Every test's pytest-timeout limit (its own ``timeout`` mark, or the configured one)
    times the wall-time scale: a limit catches a hang, and a loaded machine is no hang.

    A Hypothesis test's limit ends its process (pytest-timeout's ``thread`` method; under
    xdist the worker is reported crashed and replaced) instead of raising in the test:
    Hypothesis takes that exception for a counterexample and goes on replaying and shrinking
    the example that was too slow, with no limit left (a run of the whole suite at load 12
    stayed half an hour in one such test)."""
    factor = walltime.scale()
    if not config.pluginmanager.hasplugin("timeout"):
        return
    default = config.getoption("timeout", None) or config.getini("timeout")
    for item in items:
        mark = item.get_closest_marker("timeout")
        limit = mark.args[0] if mark is not None and mark.args else mark.kwargs.get("timeout") if mark else default
        method = mark.kwargs.get("method") if mark is not None else None
        if getattr(getattr(item, "obj", None), "is_hypothesis_test", False):
            method = method or "thread"
        if limit and (factor != 1.0 or method):
            kwargs = {"method": method} if method else {}
            item.add_marker(pytest.mark.timeout(float(limit) * factor, **kwargs), append=False)
