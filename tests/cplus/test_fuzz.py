"""Fuzzing the front end and the command line with generated hostile input.

Programs come from a grammar-based generator: C+ statements built from the language's own
constructs, with names drawn from what is declared, from keywords, from Cplus2ASP's spellings
and from nowhere, and with hostile shapes mixed in (long chains, deep nesting, runs of minus
signs, huge integers and ranges, macros that double).  Command lines combine every subcommand's
options with good and bad values and files.  Whatever comes in, the answer is a result or a
project error: no traceback, an exit code from the documented table, and a message that is
either located (``file:line:col: error:`` with the source line and a caret) or one line.
A few generated programs also run as processes under a 4 GB address-space limit.
"""
from __future__ import annotations

import re
import subprocess
import sys

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cplus import Domain
from cplus.cli import common as cli_common
from cplus.errors import CPlusError
from cplus.parser import RESERVED

PRELUDE = """:- sorts s; n. :- objects a, b :: s; 0..3 :: n.
:- variables X, Y :: s; N :: n.
:- constants p, q :: inertialFluent; c(s) :: inertialFluent(n); go(s) :: exogenousAction; r :: sdFluent;
   size :: n.
exogenous size.
"""
# (the rigid constant also keeps the generated laws clear of a known grounder bug: see
# test_an_always_violated_constraint_without_rigid_constants_has_no_plan)

LOCATED = re.compile(r"^fuzz\.cp:\d+:\d+: error: .+")
EXIT_CODES = {v for k, v in vars(cli_common).items() if k.startswith("EXIT_")}
"""The documented table (cplus/cli/common.py)."""

# ------------------------------------------------------------------ the generator

NAMES = ["p", "q", "r", "c(X)", "c(a)", "c(N)", "go(X)", "go(b)", "X", "Y", "N", "a", "b", "none", "true",
         "false", "maxstep", "m", "m(1)", "zz", "Zz", "c", "go", "c(X, Y)", "min(N, 2)", "abs(N)", "#1"]
WEIRD = sorted(RESERVED) + ["never", "impossible", "not", "infinity", "inertialFluent", "s", "n"]
BINARY = ["&", "++", ",", "&&", "||", "->>", "<->>", "<->", "=", "\\=", "==", "<", ">", "=<", ">=", "@<",
          "<=", "=>", "<>", "+", "-", "*", "//", "mod", "..", "!=", "|", "<-", ":"]
UNARY = ["-", "~", "abs ", "--", "- -"]


def integers() -> st.SearchStrategy[str]:
    return st.one_of(st.integers(-5, 9).map(str), st.sampled_from(["9223372036854775807", "9223372036854775808",
                                                                   "1" + "0" * 30, "9" * 1200, "007"]))


def expressions(clean: bool = False) -> st.SearchStrategy[str]:
    """Expressions over the prelude's names; ``clean`` keeps to declared names and CCALC's
    operators (most such programs resolve, so grounding and solving get exercised too)."""
    if clean:
        leaves = st.one_of(st.sampled_from(NAMES[:16]), st.integers(-2, 4).map(str))
        binary, unary = BINARY[:18] + ["+", "-", "*"], UNARY[:3]
    else:
        leaves = st.one_of(st.sampled_from(NAMES), st.sampled_from(WEIRD), integers())
        binary, unary = BINARY, UNARY

    def grow(inner):
        return st.one_of(
            st.tuples(inner, st.sampled_from(binary), inner).map(" ".join),
            st.tuples(st.sampled_from(unary), inner).map("".join),
            inner.map(lambda e: f"({e})"),
            st.tuples(st.sampled_from(["c", "go", "m", "max", "zz"]), st.lists(inner, min_size=1, max_size=3))
              .map(lambda t: f"{t[0]}({', '.join(t[1])})"),
            st.tuples(st.sampled_from(["\\/X", "/\\N", "\\/X \\/Y", "\\/Q"]), inner).map(lambda t: f"[{t[0]} | {t[1]}]"),
            st.tuples(st.sampled_from(["0", "1", "maxstep", "N"]), inner).map(lambda t: f"{t[0]}: {t[1]}"),
        )
    return st.recursive(leaves, grow, max_leaves=12)


def hostile_expressions(quantifiers: bool = True) -> st.SearchStrategy[str]:
    """Shapes that break naive implementations: long chains, deep nesting, long prefix runs.
    (Nested quantifiers are also exponential to ground, which is the grounder's to bound; the
    processes below leave them out.)"""
    nests = ["-(q & ", "abs(", "c(", "(", "-("] + (["[\\/X | "] if quantifiers else [])
    return st.one_of(
        st.tuples(st.sampled_from(["&", "++", ",", "+", "-", "*", "->>", "//"]), st.integers(2, 3000),
                  st.sampled_from(["q", "N", "1", "c(X)"])).map(lambda t: f" {t[0]} ".join([t[2]] * t[1])),
        st.tuples(st.integers(1, 400), st.sampled_from(nests))
          .map(lambda t: t[1] * t[0] + "q" + {"[": "]"}.get(t[1][0], ")") * t[0]),
        st.tuples(st.integers(1, 3000), st.sampled_from(["-", "~", "- "])).map(lambda t: t[1] * t[0] + "q"),
    )


def statements(quantifiers: bool = True) -> st.SearchStrategy[str]:
    e = st.one_of(expressions(), hostile_expressions(quantifiers))
    name = st.sampled_from(["p2", "k", "c", "p", "X", "if", "label", "never", "m", "cell", "inertialFluent"])
    sort = st.one_of(st.sampled_from(["s", "n", "s*", "s+none", "boolean", "zz", "step", "afValue"]),
                     st.tuples(e, e).map(lambda t: f"{t[0]}..{t[1]}"))
    kind = st.sampled_from(["inertialFluent", "simpleFluent", "sdFluent", "exogenousAction", "action", "rigid",
                            "abAction", "additiveFluent", "attribute", "bogusKind"])
    return st.one_of(
        st.tuples(st.sampled_from(["caused", "", "constraint", "always", "default", "nonexecutable", "never",
                                   "exogenous", "inertial", "rigid", "possibly caused"]), e,
                  st.lists(st.tuples(st.sampled_from(["if", "after", "where", "unless"]), e), max_size=3))
          .map(lambda t: " ".join([t[0], t[1]] + [f"{k} {v}" for k, v in t[2]]) + "."),
        st.tuples(e, st.sampled_from(["causes", "may cause", "increments"]), e, st.sampled_from(["", " by 2", " by N"]))
          .map(lambda t: f"{t[0]} {t[1]} {t[2]}{t[3]}."),
        st.tuples(st.lists(e, min_size=1, max_size=3), sort).map(lambda t: f":- objects {', '.join(t[0])} :: s."),
        st.tuples(name, st.lists(sort, max_size=2), kind, st.one_of(st.just(""), sort.map(lambda x: f"({x})")))
          .map(lambda t: f":- constants {t[0]}{'(' + ', '.join(t[1]) + ')' if t[1] else ''} :: {t[2]}{t[3]}."),
        st.tuples(st.sampled_from(["X", "Z", "x", "N"]), sort).map(lambda t: f":- variables {t[0]} :: {t[1]}."),
        st.tuples(name, st.sampled_from(["", "(#1)", "(#1, #2)", "(#2)"]), e).map(lambda t: f":- macros {t[0]}{t[1]} -> {t[2]}."),
        st.integers(2, 70).map(lambda k: ":- macros d0 -> q.\n" + "".join(
            f":- macros d{i + 1} -> d{i} & d{i}.\n" for i in range(k)) + f"caused p if d{k}."),
        st.tuples(st.one_of(integers(), name), st.one_of(integers(), st.tuples(e, e).map("..".join),
                                                          st.just("0..infinity")), st.lists(e, max_size=2))
          .map(lambda t: f":- query label :: {t[0]}; maxstep :: {t[1]}{''.join('; ' + x for x in t[2])}."),
        st.sampled_from([":- sorts t >> (u; v >> w) >> x.", ":- sorts s.", ":- sorts step.", ":- include 'none.cp'.",
                         ":- show c(X); p.", ":- hide all.", ":- maxAdditive :: 3.", "noconcurrency.",
                         ":- begin_asp.\nfoo :- bar.\n:- end_asp.", ":- foo.", "p.q.", "/* open", "'x", "caused p",
                         "\ufeff:- sorts z."]),
    )


programs = st.lists(statements(), min_size=1, max_size=6).map(lambda ss: PRELUDE + "\n".join(ss) + "\n")


def check_error(err: CPlusError) -> None:
    rendered = err.render()
    lines = rendered.splitlines()
    if err.loc is None:
        assert len(lines) == 1 and lines[0].startswith("error: "), rendered
    else:
        assert LOCATED.match(lines[0]), rendered
        assert len(lines) == 3 and "^" in lines[2], rendered


# ------------------------------------------------------------------ properties


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(programs)
def test_generated_programs_load_or_fail_with_a_located_error(text):
    try:
        domain = Domain.from_text(text, "fuzz.cp")
    except CPlusError as err:
        check_error(err)
        return
    assert domain.program.signature.finalized


ATOMS = ["p", "q", "r", "-p", "-r", "c(X) = N", "c(a) = 2", "c(X) = c(Y)", "go(X)", "-go(a)", "X = a", "N < 2",
         "N + 1 = c(X)", "true", "false", "X @< Y", "c(X) < N", "c(b) \\= size", "size >= 2", "~q", "--p"]
HEADS = ["p", "-p", "q", "r", "-r", "c(X) = N", "c(a) = 1", "c(X) = N + 1", "false", "true", "p & -q", "-true"]


def formulas() -> st.SearchStrategy[str]:
    """Well-typed formulas over the prelude: most generated laws resolve and get grounded."""
    def grow(inner):
        return st.one_of(
            st.tuples(inner, st.sampled_from(["&", "++", "->>", "<->>", ",", "&&", "||"]), inner)
              .map(lambda t: f"({t[0]} {t[1]} {t[2]})"),
            inner.map(lambda f: f"-({f})"),
            st.tuples(st.sampled_from(["\\/X", "/\\N", "\\/Y /\\X"]), inner).map(lambda t: f"[{t[0]} | {t[1]}]"),
        )
    return st.recursive(st.sampled_from(ATOMS), grow, max_leaves=6)


SMALL = st.lists(st.one_of(
    st.tuples(st.sampled_from(["caused", "default"]), st.sampled_from(HEADS),
              st.sampled_from(["if", "after"]), formulas(), st.sampled_from(["", " where N < 2", " where X @< Y"]))
      .map(lambda t: f"{t[0]} {t[1]} {t[2]} {t[3]}{t[4]}."),
    st.tuples(st.sampled_from(["constraint", "never", "always"]), formulas()).map(lambda t: f"{t[0]} {t[1]}."),
    st.tuples(st.sampled_from(["go(X)", "go(a) & -go(b)"]), st.sampled_from(["causes", "may cause"]),
              st.sampled_from(HEADS), formulas()).map(lambda t: f"{t[0]} {t[1]} {t[2]} if {t[3]}."),
    st.tuples(st.sampled_from(["go(X)", "go(X) & go(Y)"]), formulas()).map(lambda t: f"nonexecutable {t[0]} if {t[1]}."),
    st.tuples(st.sampled_from(["caused", "constraint"]), expressions(clean=True)).map(lambda t: f"{t[0]} {t[1]}."),
), min_size=1, max_size=4).map(lambda ss: PRELUDE + "\n".join(ss) + "\n:- query maxstep :: 0..1.\n")


@settings(max_examples=150, suppress_health_check=[HealthCheck.too_slow])
@given(SMALL)
def test_generated_laws_plan_or_fail_with_a_located_error(text):
    """Past the front end too: grounding and solving small domains (two objects, four numbers)."""
    try:
        domain = Domain.from_text(text, "fuzz.cp")
        result = domain.solve("0", solutions=2)
    except CPlusError as err:
        check_error(err)
        return
    assert result.status.value in ("found", "no_plan")
    domain.format(result)
    domain.to_json(result)


@pytest.mark.parametrize("law", ["constraint false.", "constraint p == q."])
def test_an_always_violated_constraint_without_rigid_constants_has_no_plan(law):
    """Found by the fuzzing above: every domain with this law has no history."""
    domain = Domain.from_text(f":- constants p, q :: inertialFluent.\n{law}\n:- query maxstep :: 0.")
    assert domain.solve("0").status.value == "no_plan"


# ------------------------------------------------------------------ the command line

COMMAND_OPTIONS = {
    "plan": ["--query", "-q", "-n", "--json", "--stats", "--solver", "--max-horizon", "--extern", "--plot",
             "--no-refine", "--max-iterations", "--points-per-step", "--step-time"],
    "ground": ["--maxstep", "--dimacs", "--query", "-q", "--extern"],
}
VALUES = ["0", "1", "2", "-1", "x", "", "on", "states", "never", "glucose4", "nope", "1e9", "/no/such.py", "-",
          "--json"]   # (no huge maxstep: bounding the horizon belongs to the grounder)


def command_lines(files: dict[str, str]):
    command = st.sampled_from(["plan", "ground", "bogus", "--version", "-h", "--help", "-V"])
    option = st.one_of(st.tuples(st.sampled_from(COMMAND_OPTIONS["plan"] + COMMAND_OPTIONS["ground"])),
                       st.tuples(st.sampled_from(COMMAND_OPTIONS["plan"] + COMMAND_OPTIONS["ground"]),
                                 st.sampled_from(VALUES)))
    target = st.sampled_from(sorted(files) + ["/dev/zero", "/no/such.cp", "-", ".", ""])
    return st.tuples(command, st.lists(target, max_size=2), st.lists(option, max_size=4)).map(
        lambda t: [t[0], *t[1], *[x for opt in t[2] for x in opt]])


def _files(root) -> dict[str, str]:
    texts = {
        "lamp.cp": ":- constants lit :: inertialFluent; flip :: exogenousAction.\nflip causes lit.\n"
                   ":- query label :: on; maxstep :: 0..2; 0: -lit; maxstep: lit.\n"
                   ":- query label :: never; maxstep :: 1; 0: -lit; 1: -lit; 0: flip.\n",
        "open.cp": ":- constants lit :: inertialFluent.\n:- query maxstep :: 0..infinity; maxstep: lit & -lit.\n",
        "bad.cp": ":- constants lit :: inertialFluent.\ncaused lit if if lit.\n",
        "deep.cp": "caused p if " + "-(q & " * 300 + "q" + ")" * 300 + ".\n",
        "huge.cp": ":- sorts n. :- objects 1..99999999999 :: n.\n",
    }
    out = {}
    for name, text in texts.items():
        (root / name).write_text(text)
        out[str(root / name)] = text
    return out


@settings(max_examples=200, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_generated_command_lines_keep_the_exit_code_table(tmp_path_factory, data):
    import contextlib
    import io

    from cplus.cli import main
    root = tmp_path_factory.mktemp("cli")
    files = _files(root)
    argv = data.draw(command_lines(files))
    if argv[0] == "plan":
        argv += ["--max-horizon", "3"]   # an open range with no plan runs for ever, as in CCALC
    out, err = io.StringIO(), io.StringIO()
    with contextlib.chdir(root), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    message = err.getvalue()
    assert code in EXIT_CODES, (argv, code, message)
    assert "Traceback" not in message, (argv, message)
    if code == 2:   # the error is the first line that is not a warning about an ignored option
        first = next(line for line in message.splitlines() if ": warning: " not in line)
        assert re.match(r"^(\S+:\d+:\d+: error: |error: |cplus( \w+)?: error: |usage: )", first), (argv, message)


# ------------------------------------------------------------------ in a box

@settings(max_examples=8, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(text=st.lists(st.one_of(statements(False), hostile_expressions(False).map(lambda e: f"caused p if {e}.")),
                     min_size=1, max_size=3).map(lambda ss: PRELUDE + "\n".join(ss) + "\n"))
def test_generated_programs_as_processes_under_4_gb(tmp_path_factory, text):
    from test_hostile import _limited
    path = tmp_path_factory.mktemp("box") / "fuzz.cp"
    path.write_text(text)
    # one horizon: how long a horizon may be ('maxstep :: 9223372036854775807') is the
    # grounder's to bound, not the front end's
    proc = subprocess.run([sys.executable, "-m", "cplus", "ground", "fuzz.cp", "--maxstep", "1", "--dimacs", "out.cnf"],
                          capture_output=True, timeout=300, preexec_fn=_limited, cwd=path.parent)
    message = proc.stderr.decode()
    assert proc.returncode in EXIT_CODES and "Traceback" not in message, message
    if proc.returncode == 2:
        assert re.match(r"^(fuzz\.cp:\d+:\d+: error: |error: )", message), message
