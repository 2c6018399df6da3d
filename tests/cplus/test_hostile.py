"""Hostile input: huge, deep and malformed sources end in one located error (exit 2), quickly
and in bounded memory, never in a traceback, a hang or an exhausted machine; long but
legitimate input (thousands of conjuncts, long sums, runs of minus signs) simply works.

The limits are in :mod:`cplus.limits`; each test names the number it expects in the message.
"""
from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import threading

import pytest

from cplus import Domain
from cplus.errors import CPlusError
from cplus.limits import MAX_EXPANDED, MAX_EXPANSION, MAX_FILE_BYTES, MAX_NESTING
from cplus.load import load_program, load_text

BASE = ":- constants p, q :: inertialFluent; a :: exogenousAction.\n"
NUMS = ":- sorts n. :- objects 0..3 :: n. :- variables X :: n.\n"


def error(text: str) -> CPlusError:
    with pytest.raises(CPlusError) as info:
        Domain.from_text(text, "h.cp").theory   # noqa: B018 - grounding is part of loading here
    return info.value


def count_histories(text: str) -> int:
    return len(Domain.from_text(text).solve("0", solutions=0).histories)


# --------------------------------------------------------------------------- long is fine


@pytest.mark.parametrize("n", [500, 5000])
def test_thousands_of_conjuncts(n):
    text = (":- constants q, r :: inertialFluent; s :: sdFluent.\ndefault -s.\n"
            "caused s if " + " & ".join(["q"] * (n - 1)) + " & -r.\n:- query maxstep :: 0; 0: s.")
    (hist,) = Domain.from_text(text).solve("0", solutions=0).histories
    assert hist.state_values(0) == {"q": True, "r": False, "s": True}


def test_a_thousand_term_sum_has_its_value():
    terms = [str(k) for k in range(1, 1001)]
    signs = ["+" if k % 3 else "-" for k in range(1, 1000)]
    text = terms[0] + "".join(f" {s} {t}" for s, t in zip(signs, terms[1:]))
    expected = eval(text)   # noqa: S307 - our own arithmetic
    prog = load_text(f":- sorts n. :- objects {text} :: n.")
    assert prog.signature.sorts["n"].objects == [expected]


def test_a_thousand_term_product_and_a_long_sum_with_variables():
    law = "caused p if X = " + " + ".join(["X"] * 999) + " - " + " - ".join(["X"] * 998) + " where X < 2."
    assert count_histories(NUMS + BASE + law + "\n:- query maxstep :: 0; 0: p.") == 2
    assert load_text(":- sorts n. :- objects " + " * ".join(["1"] * 1000) + " :: n.").signature.sorts["n"].objects == [1]


@pytest.mark.parametrize("k, negated", [(999, True), (1000, False), (1001, True)])
def test_runs_of_negations_mean_their_parity(k, negated):
    text = f":- constants q :: inertialFluent; s :: sdFluent.\ndefault -s.\ncaused s if {'-' * k}q.\n" \
           ":- query maxstep :: 0; 0: s."
    (hist,) = Domain.from_text(text).solve("0", solutions=0).histories
    assert hist.value("q", 0) is (not negated)


def test_runs_of_unary_minus_mean_their_parity():
    assert load_text(":- sorts n. :- objects " + "- " * 1001 + "4 :: n.").signature.sorts["n"].objects == [-4]
    assert load_text(":- sorts n. :- objects " + "- " * 1000 + "4 :: n.").signature.sorts["n"].objects == [4]


def test_nesting_up_to_the_limit_plans():
    """MAX_NESTING levels of real nesting run through every pass (grounding and encoding
    included) without exhausting Python's stack, even with the test runner's frames below."""
    body = "q"
    for _ in range(MAX_NESTING // 2 - 1):
        body = f"-(q & {body})"
    assert count_histories(BASE + f"caused p if {body}.\n:- query maxstep :: 1.") > 0


def test_nesting_past_the_limit_is_located():
    body = "q"
    for _ in range(MAX_NESTING // 2 + 1):
        body = f"-(q & {body})"
    err = error(BASE + f"caused p if {body}.")
    assert f"nested more than {MAX_NESTING} levels deep" in err.message and err.loc.line == 2


# --------------------------------------------------------------------------- too large is refused


@pytest.mark.parametrize("text, line, col, fragment", [
    (":- sorts n. :- objects 1..1000000000 :: n.", 1, 24,
     "the range 1..1000000000 declares 1,000,000,000 objects; a domain may declare at most 1,000,000"),
    (":- sorts n. :- objects cell(1..1000, 1..1000, 1..1000) :: n.", 1, 24,
     "'cell(...)' declares 1,000,000,000 objects"),
    (":- sorts n. :- objects 1..600000 :: n.\n:- objects 1000000..1500000 :: n.", 2, 12,
     "declares 500,001 objects; a domain may declare at most 1,000,000 objects in all (600,002 are declared"),
    (":- constants c :: inertialFluent(0..1000000000).", 1, 34, "the range 0..1000000000 has 1,000,000,001 integers"),
    (":- variables X :: -5000000..5000000.", 1, 19, "has 10,000,001 integers"),
    (":- sorts n. :- objects 1..300 :: n.\n:- constants c(n, n, n) :: inertialFluent.", 2, 14,
     "'c/3' has 27,000,000 ground instances (300 x 300 x 300)"),
    (":- sorts n. :- objects " + "9" * 1000 + " :: n.", 1, 24, "(1000 digits) is too large"),
    (":- sorts n. :- objects 1.." + "9" * 20 + " :: n.", 1, 27, "99999999999999999999 is too large"),
    (":- query maxstep :: " + "9" * 5000 + ".", 1, 21, "(5000 digits) is too large"),
    (":- sorts n. :- objects 4611686018427387904 * 4 :: n.", 1, 24, "is outside the integers"),
])
def test_sizes_past_the_limits_are_refused_with_the_number(text, line, col, fragment):
    err = error(text)
    assert fragment in err.message, err.message
    assert (err.loc.line, err.loc.col) == (line, col)


def test_a_macro_that_doubles_at_each_level_is_refused_with_its_size():
    macros = ":- macros m0 -> q.\n" + "".join(f":- macros m{i + 1} -> m{i} & m{i}.\n" for i in range(60))
    err = error(BASE + macros + "caused p if m60.")
    assert err.message == ("expanding the macros here gives an expression of 2,305,843,009,213,693,951 nodes; "
                           f"the limit is {MAX_EXPANSION:,}")
    assert (err.loc.line, err.loc.col) == (63, 13)


def test_a_parameterised_macro_that_doubles_is_refused_too():
    err = error(BASE + ":- macros d(#1) -> (#1 & #1).\ncaused p if " + "d(" * 40 + "q" + ")" * 40 + ".")
    assert "gives an expression of 2,199,023,255,551 nodes" in err.message


def test_macros_calling_macros_too_deeply_are_refused():
    macros = ":- macros m0 -> q.\n" + "".join(f":- macros m{i + 1} -> m{i}.\n" for i in range(MAX_NESTING + 5))
    err = error(BASE + macros + f"caused p if m{MAX_NESTING + 5}.")
    assert f"more than {MAX_NESTING} levels deep" in err.message


def test_macro_expansion_has_a_budget_for_the_whole_domain():
    """Each use is below the per-expression limit, together they are not."""
    macros = ":- macros m0 -> q.\n" + "".join(f":- macros m{i + 1} -> m{i} & m{i}.\n" for i in range(14))
    laws = "".join("caused p if m14 & q.\n" for _ in range(10))   # 32,769 nodes each
    err = error(BASE + macros + laws)
    assert f"macro expansion has produced more than {MAX_EXPANDED:,} nodes" in err.message
    assert err.loc.line == 17 + MAX_EXPANDED // 32_770


# --------------------------------------------------------------------------- files


def test_a_device_is_refused_without_reading_it():
    with pytest.raises(CPlusError, match="'/dev/zero' is a character device, not a C\\+ file"):
        load_program("/dev/zero")


def test_a_directory_is_refused(tmp_path):
    with pytest.raises(CPlusError, match="is a directory, not a C\\+ file"):
        load_program(str(tmp_path))


def test_a_huge_file_is_refused_by_its_size(tmp_path):
    path = tmp_path / "huge.cp"
    with open(path, "wb") as fh:
        fh.truncate(MAX_FILE_BYTES + 1)   # sparse: no disk space used
    with pytest.raises(CPlusError, match=f"has {MAX_FILE_BYTES + 1:,} bytes; a C\\+ file may have at most"):
        load_program(str(path))


def test_a_pipe_is_read_up_to_the_limit(tmp_path):
    fifo = tmp_path / "domain.cp"
    os.mkfifo(fifo)

    def write(data: bytes) -> None:
        with open(fifo, "wb") as fh:
            try:
                fh.write(data)
            except BrokenPipeError:
                pass
    writer = threading.Thread(target=write, args=(b":- constants p :: inertialFluent.\n",))
    writer.start()
    assert load_program(str(fifo)).signature.lookup("p", 0) is not None
    writer.join()
    writer = threading.Thread(target=write, args=(b"% " + b"x" * MAX_FILE_BYTES,))
    writer.start()
    with pytest.raises(CPlusError, match=f"has more than {MAX_FILE_BYTES:,} bytes"):
        load_program(str(fifo))
    writer.join()


# --------------------------------------------------------------------------- the command, in a box

FOUR_GB = 4 * 1024 ** 3


def _limited() -> None:   # pragma: no cover - runs in the child
    resource.setrlimit(resource.RLIMIT_AS, (FOUR_GB, FOUR_GB))


def cplus(args: list[str], stdin: bytes | None = None, timeout: float = 120) -> subprocess.CompletedProcess:
    """``cplus ARGS`` as a process limited to 4 GB of address space."""
    return subprocess.run([sys.executable, "-m", "cplus", *args], input=stdin, capture_output=True,
                          timeout=timeout, preexec_fn=_limited)


def hostile_files() -> dict[str, str]:
    doubling = ":- macros m0 -> q.\n" + "".join(f":- macros m{i + 1} -> m{i} & m{i}.\n" for i in range(60))
    return {
        "range": ":- sorts n. :- objects 1..1000000000 :: n.",
        "digits": ":- sorts n. :- objects " + "7" * 1000 + " :: n.",
        "macro": BASE + doubling + "caused p if m60.",
        "nesting": BASE + "caused p if " + "-(q & " * 200 + "q" + ")" * 200 + ".",
        "keyword": BASE + "caused p if if q.",
        "product": ":- sorts n. :- objects 1..300 :: n.\n:- constants c(n, n, n) :: inertialFluent.",
    }


@pytest.mark.parametrize("name", sorted(hostile_files()))
def test_hostile_files_end_in_one_located_error(tmp_path, name):
    path = tmp_path / f"{name}.cp"
    path.write_text(hostile_files()[name])
    proc = cplus(["plan", str(path)])
    err = proc.stderr.decode()
    assert proc.returncode == 2, err
    assert err.startswith(f"{path}:") and ": error: " in err.splitlines()[0]
    assert len(err.splitlines()) == 3 and "Traceback" not in err   # message, source line, caret
    assert proc.stdout == b""


def test_dev_zero_is_one_line():
    proc = cplus(["plan", "/dev/zero"], timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.decode() == "cplus plan: error: '/dev/zero' is a character device, not a C+ file\n"


def test_long_input_plans_in_the_box(tmp_path):
    path = tmp_path / "long.cp"
    path.write_text(BASE + "caused p if " + " & ".join(["q"] * 5000) + ".\n"
                    + "caused p if " + "-" * 1000 + "q.\n:- query maxstep :: 0; 0: p.")
    proc = cplus(["plan", str(path), "-n", "0"])
    assert proc.returncode == 0, proc.stderr.decode()
    assert proc.stdout.decode().count("Solution") == 2


# --------------------------------------------------------------------------- external functions
# issue 30: externals returning None, '1' or 10**30 silently meant "No solution", sys.exit(0)
# ended the run with nothing printed, and a print went into the JSON.

HOPS = """:- sorts cell. :- objects 0..6 :: cell. :- variables C, D :: cell.
:- constants at :: inertialFluent(cell); go(cell) :: exogenousAction.
go(C) causes at=C.
nonexecutable go(C) if at=D where -near(C, D).
nonexecutable go(C) & go(D) where C @< D.
:- query maxstep :: 0..10; 0: at=0; maxstep: at=double(3).
"""
NEAR, DOUBLE = "return abs(x - y) <= 1", "return 2 * x"


def hops(tmp_path, near: str = NEAR, double: str = DOUBLE, top: str = "") -> tuple[str, str]:
    domain, ext = tmp_path / "hops.cp", tmp_path / "ext.py"
    domain.write_text(HOPS)
    ext.write_text(f"{top}\n\ndef near(x, y):\n    {near}\n\n\ndef double(x):\n    {double}\n")
    return str(domain), str(ext)


def plan(argv: list[str], capsys) -> tuple[int, str, str]:
    from cplus.cli import main
    code = main(argv)
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


NEAR_CALL = ":4:36: error: external predicate 'near(0,0)' returned "
DOUBLE_CALL = ":6:49: error: external 'double(3)' returned "


@pytest.mark.parametrize("near, double, message", [
    ("return None", DOUBLE, NEAR_CALL + "None, not True or False"),
    ("return '1'", DOUBLE, NEAR_CALL + "'1', not True or False"),
    ("return 1", DOUBLE, NEAR_CALL + "1, not True or False"),
    (NEAR, "return 10 ** 30", DOUBLE_CALL + "about 10^30, outside the integers (-2^63..2^63-1)"),
    (NEAR, "return 2 ** 63", DOUBLE_CALL + "9,223,372,036,854,775,808, outside the integers (-2^63..2^63-1)"),
    (NEAR, "return '6'", DOUBLE_CALL + "'6', which is neither an integer nor an object of this domain"),
    (NEAR, "return 6.0", DOUBLE_CALL + "6.0, which is neither an integer nor an object of this domain"),
    (NEAR, "return True", DOUBLE_CALL + "True, which is neither an integer nor an object of this domain"),
    (NEAR, "return None", DOUBLE_CALL + "None, which is neither an integer nor an object of this domain"),
    ("import sys; sys.exit(0)", DOUBLE, ":4:36: error: external 'near(0,0)' tried to end the program (sys.exit(0))"),
    ("raise KeyError(x)", DOUBLE, ":4:36: error: external 'near(0,0)' failed: KeyError: 0"),
])
def test_an_external_that_returns_what_it_may_not_is_a_located_error(tmp_path, capsys, near, double, message):
    domain, ext = hops(tmp_path, near, double)
    code, out, err = plan(["plan", domain, "--extern", ext, "--json"], capsys)
    assert code == 2 and out == ""
    assert err.startswith(domain + message + "\n"), err


def test_numpy_values_are_what_they_mean(tmp_path, capsys):
    domain, ext = hops(tmp_path, "return numpy.bool_(abs(x - y) <= 1)", "return numpy.int64(2 * x)",
                       top="import numpy")
    code, out, _ = plan(["plan", domain, "--extern", ext], capsys)
    assert code == 0 and "6:  at=6" in out


def test_what_an_external_prints_goes_to_standard_error_and_the_json_stays_whole(tmp_path, capfd):
    """Python's print, a write to file descriptor 1, C's printf and a child process, while the
    file loads and while a function runs: all on standard error, the JSON alone on standard
    output."""
    from cplus.cli import main
    loud = ("print('py', x, y); os.write(1, b'fd\\n'); libc.printf(b'c-level\\n'); "
            "subprocess.run(['echo', 'child']); return abs(x - y) <= 1")
    domain, ext = hops(tmp_path, loud, top="import ctypes, os, subprocess\nlibc = ctypes.CDLL(None)\n"
                                          "print('loading')")
    code = main(["plan", domain, "--extern", ext, "--json"])
    out, err = capfd.readouterr()
    assert code == 0
    (result,) = json.loads(out)["results"]
    assert result["maxstep"] == 6
    assert err.count("loading") == 1 and "py 0 0" in err
    assert err.count("fd\n") == err.count("c-level\n") == err.count("child\n") == err.count("py ") > 0


def test_an_extern_file_that_exits_while_loading_is_one_line(tmp_path, capsys):
    domain, ext = hops(tmp_path, top="import sys\nsys.exit(3)")
    code, out, err = plan(["plan", domain, "--extern", ext], capsys)
    assert code == 2 and out == ""
    assert err == f"cplus plan: error: loading extern file '{ext}' tried to end the program (sys.exit(3))\n"
