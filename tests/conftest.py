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
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

ROOT = Path(__file__).resolve().parent.parent
CORPUS = Path(os.environ.get("CPLUS_CORPUS", ROOT / "tests" / "corpus"))

settings.register_profile("cplus", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("cplus")


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--run-nxt", metavar="PORT", default=None,
                     help="run the tests marked 'hardware' against a real NXT brick on this serial "
                          "port (e.g. /dev/rfcomm0); without it they are skipped")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
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
