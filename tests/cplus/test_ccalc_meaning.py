"""CCALC's meaning where cplus used to read a construct its own way: `-c=v`, a query without maxstep, show specifications, nmquery.

Each test has CCALC's answer written in it: from CCALC 2's source (ccalc.pl: ``process_query``,
``nmquery_aux``, ``generate_completion_clauses(query)``, ``in_show_list``) or its semantics.
"""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from cplus import Domain
from cplus.errors import CPlusError

LAMP = """:- constants lit :: inertialFluent; flip :: exogenousAction.
flip causes lit.
"""


def histories(src: str, label: str = "0", nmquery: bool = False):
    d = Domain.from_text(src)
    return d.solve(label, solutions=0, nmquery=nmquery)


# ----------------------------------------------------------------------------- -c=v

def test_minus_before_a_comparison_is_arithmetic_minus_with_a_warning():
    """CCALC: `0: -c=1` is `(-c)=1`, c = -1, out of 0..2: "No solution with maxstep 0."
    (here it used to give c=0 or c=2)."""
    d = Domain.from_text(":- constants c :: simpleFluent(0..2). :- query maxstep :: 0; 0: -c=1.")
    assert d.solve(solutions=0).histories == []
    assert any("means '(-c)'" in w.message and "-(c=v)" in w.message for w in d.diagnostics.items)
    # `-(c=1)` is the negation: c is 0 or 2
    r = histories(":- constants c :: simpleFluent(0..2). :- query maxstep :: 0; 0: -(c=1).")
    assert sorted(h.value("c", 0) for h in r.histories) == [0, 2]
    # `-c=-2` holds for c = 2 only
    r = histories(":- constants c :: simpleFluent(0..2). :- query maxstep :: 0; 0: -c = -2.")
    assert [h.value("c", 0) for h in r.histories] == [2]


def test_minus_before_a_comparison_changes_a_law_body():
    """`caused lit if -dir=3`: CCALC reads dir = -3, never true here, so lit is never caused."""
    src = """:- constants dir :: simpleFluent(0..3); lit :: sdFluent.
caused lit if -dir=3. default -lit.
:- query maxstep :: 0; 0: lit."""
    assert histories(src).histories == []
    assert len(histories(src.replace("-dir=3", "-(dir=3)")).histories) == 3


def test_minus_before_a_comparison_of_a_non_integer_constant_is_refused():
    """CCALC: `Invalid expression`; the error says what to write instead."""
    d = Domain.from_text(":- sorts s. :- objects a, b :: s. :- constants c :: simpleFluent(s).\n"
                         ":- query maxstep :: 0; 0: -c=a.")
    with pytest.raises(CPlusError) as exc:
        d.solve()
    assert "2:27" in str(exc.value.loc) and "write '-(c=...)'" in exc.value.message


# ----------------------------------------------------------------------------- a bad query alone

BAD_FIRST = """:- constants p, q :: inertialFluent.
:- query label :: 1; maxstep :: 0; 0: -p=true.
:- query label :: 2; maxstep :: 0; 0: q & -p.
:- query label :: 1; maxstep :: 0; 0: p.
"""


def test_a_bad_query_fails_alone_and_keeps_its_label():
    """CCALC fails the query `-p=true` (p Boolean: Invalid expression) when it is asked and
    answers the others; the later query of label 1 stays ignored (the first of a label wins)."""
    d = Domain.from_text(BAD_FIRST)
    assert d.labels == ["1", "2"]
    with pytest.raises(CPlusError) as exc:
        d.query("1")
    assert str(exc.value.loc).endswith(":2:39") and "Invalid expression" in exc.value.message
    with pytest.raises(CPlusError):
        d.solve("1")
    [h] = d.solve("2").histories
    assert h.value("q", 0) is True and h.value("p", 0) is False
    assert any("label '1' is used again" in w.message for w in d.diagnostics.items)


def test_a_query_with_a_bad_label_still_refuses_the_file():
    """Nothing to hold the error under: the file is refused, as before."""
    with pytest.raises(CPlusError):
        Domain.from_text(":- constants p :: inertialFluent.\n:- query label :: p + 1; maxstep :: 0.\n")


def test_cplus_plan_answers_the_other_queries_of_a_file_with_a_bad_one(tmp_path):
    f = tmp_path / "bad.cp"
    f.write_text(BAD_FIRST)
    run = lambda *a: subprocess.run([sys.executable, "-m", "cplus", "plan", str(f), *a],  # noqa: E731
                                    capture_output=True, text=True, timeout=120)
    every = run()
    assert every.returncode == 2
    assert every.stdout == "% query 1\n% query 2\n\n0:  q\n\n\n"
    assert every.stderr.count(f"{f}:2:39: error: ") == 1 and "Traceback" not in every.stderr
    doc = json.loads(run("--json").stdout)
    assert [r["query"]["label"] for r in doc["results"]] == ["2"]
    alone = run("--query", "1")
    assert alone.returncode == 2 and alone.stdout == "" and f"{f}:2:39: error: " in alone.stderr
    other = run("--query", "2")
    assert other.returncode == 0 and "0:  q" in other.stdout
    cnf = tmp_path / "q1.cnf"
    ground = subprocess.run([sys.executable, "-m", "cplus", "ground", str(f), "--query", "1", "--maxstep", "0",
                             "--dimacs", str(cnf)], capture_output=True, text=True, timeout=120)
    assert ground.returncode == 2 and f"{f}:2:39: error: " in ground.stderr and not cnf.exists()


# ----------------------------------------------------------------------------- maxstep

def test_a_query_without_maxstep_is_answered_at_maxstep_0():
    """CCALC (process_query): `MaxStep2 = 0` when the query gives none: "No solution with
    maxstep 0." where a plan needs a step (here it used to search upwards)."""
    r = histories(LAMP + ":- query 0: -lit; maxstep: lit.")
    assert (r.histories, r.failed) == ([], [0])
    assert r.status.value == "no_plan"


# ----------------------------------------------------------------------------- var(s, k)

def test_anonymous_variables_may_be_quantified():
    """CCALC's zoo test quantifies `var(step, a)`."""
    r = histories(LAMP + ":- query maxstep :: 2; 0: -lit; [\\/var(step,a) | var(step,a) < maxstep & "
                  "(var(step,a): flip)]; 2: -flip.")
    assert r.maxstep == 2 and r.histories and all(any(h.value("flip", t) for t in (0, 1)) for h in r.histories)


# ----------------------------------------------------------------------------- nmquery

NM = LAMP + """
:- nmquery label :: 0; maxstep :: 1;
   default 0: lit; default 0: -lit; default 0: flip; default 0: -flip;
   caused 1: lit if 0: flip; default 1: -lit.
:- query maxstep :: 1; (0: flip) ->> (1: lit).
"""


def test_an_nmquery_is_completed_on_its_own():
    """The nmquery's completion says `1: lit <-> 0: flip`: with the domain's (`1: lit <-> 0: flip
    ++ 0: lit`) the history where lit only persists by inertia is gone (3 histories); the query
    with the rule read as a formula keeps all 4."""
    assert len(histories(NM).histories) == 4
    nm = histories(NM, nmquery=True)
    assert len(nm.histories) == 3
    assert all(h.value("flip", 0) or not h.value("lit", 0) for h in nm.histories)


def test_an_nmquery_whose_query_form_is_inconsistent():
    """`default 0: lit; default 0: -lit` leaves lit free; as query items `0: lit; 0: -lit` it
    is inconsistent."""
    src = LAMP + """:- nmquery label :: 1; maxstep :: 0; default 0: lit; default 0: -lit.
:- query label :: 1; maxstep :: 0; 0: lit; 0: -lit."""
    assert histories(src, "1").histories == []
    assert len(histories(src, "1", nmquery=True).histories) == 2


def test_an_atom_no_nmquery_rule_causes_is_false():
    """Literal completion of the nmquery's rules: `0: lit` alone (caused lit) makes lit true,
    and an nmquery that causes neither flip nor -flip has no history at maxstep 1."""
    src = LAMP + ":- nmquery maxstep :: 0; 0: lit.\n:- nmquery label :: 2; maxstep :: 1; 0: lit."
    assert [h.value("lit", 0) for h in histories(src, nmquery=True).histories] == [True]
    assert histories(src, "2", nmquery=True).histories == []


def test_queries_and_nmqueries_have_their_own_labels():
    d = Domain.from_text(NM)
    assert d.labels == ["0"] and d.nm_labels == ["0"]
    with pytest.raises(CPlusError, match="no nmquery with label 'x'"):
        d.solve("x", nmquery=True)


def test_the_head_of_an_nmquery_rule_is_a_literal():
    d = Domain.from_text(LAMP + ":- nmquery maxstep :: 0; caused (0: lit) ++ (0: -lit).")
    with pytest.raises(CPlusError, match="nmquery rule"):
        d.nmquery("0")


def test_cplus_plan_nmquery(tmp_path):
    f = tmp_path / "nm.cp"
    f.write_text(NM)
    run = lambda *a: subprocess.run([sys.executable, "-m", "cplus", "plan", str(f), *a],  # noqa: E731
                                    capture_output=True, text=True, timeout=120)
    out = run("--nmquery", "0", "-n", "0")
    assert out.returncode == 0 and out.stdout.count("Solution") == 3
    doc = json.loads(run("--nmquery", "0", "--json").stdout)
    assert doc["results"][0]["query"]["kind"] == "nmquery"
    both = run()
    assert "% query 0" in both.stdout and "% nmquery 0" in both.stdout
    bad = run("--nmquery", "nope")
    assert bad.returncode == 2 and "cplus plan: error: --nmquery nope: no nmquery with label 'nope'" in bad.stderr


# ----------------------------------------------------------------------------- declarations

def test_a_law_may_name_a_constant_declared_after_it():
    """CCALC grounds the laws once the whole file is read (its traffic examples rely on it)."""
    src = """:- sorts s. :- objects x, y :: s. :- variables X :: s.
caused p(X) if q.
:- constants p(s), q :: sdFluent.
caused q if r. default -q. default -p(X).
:- constants r :: simpleFluent.
:- query maxstep :: 0; 0: r."""
    (h,) = histories(src).histories
    assert h.state_values(0) == {"p(x)": True, "p(y)": True, "q": True, "r": True}
    with pytest.raises(CPlusError, match="unknown name 'zz'"):
        Domain.from_text(":- constants p :: inertialFluent.\ncaused p if zz.")


def test_a_domain_of_statically_determined_fluents_prints_them():
    """Kept on purpose (docs/language.md, section 10): CCALC prints no fluent of such a domain."""
    d = Domain.from_text(":- constants q :: sdFluent. caused q. :- query maxstep :: 0; 0: q.")
    assert d.format(d.solve()).strip() == "0:  q"


# ----------------------------------------------------------------------------- stamped facts

def test_a_time_stamped_fact_restricts_the_histories():
    """`0: -lit.` outside a query is `caused -lit` at step 0: at maxstep 1 the lamp has 4
    histories (lit at 0 or not, flip or not); with the fact, the 2 starting dark."""
    q = ":- query maxstep :: 1; true."
    assert len(histories(LAMP + q).histories) == 4
    d = Domain.from_text(LAMP + "0: -lit.\n" + q)
    r = d.solve(solutions=0)
    assert len(r.histories) == 2 and all(not h.value("lit", 0) for h in r.histories)
    assert not d.diagnostics.items                      # no warning: this is its meaning


def test_a_time_stamped_fact_can_make_a_query_unsatisfiable():
    """`0: -lit.` and a query asking `0: lit`: no history at maxstep 0 ("No solution")."""
    r = histories(LAMP + "0: -lit.\n:- query maxstep :: 0; 0: lit.")
    assert (r.histories, r.failed) == ([], [0])


def test_a_stamped_fact_is_a_cause_not_a_condition():
    """Issue 32's minimal inputs, with CCALC's answers: `0: q.` causes the sdFluent q at 0
    (2 solutions: p free), and `1: p.` causes p at 1 with no action (0: / 1: p); read as
    conditions, both had no history."""
    r = histories(":- constants q :: sdFluent; p :: inertialFluent.\n0: q.\n"
                  ":- query label :: 1; maxstep :: 0.", "1")
    assert sorted((h.value("q", 0), h.value("p", 0)) for h in r.histories) == [(True, False), (True, True)]
    d = Domain.from_text(":- constants p :: inertialFluent; a :: exogenousAction.\nnonexecutable a.\n1: p.\n"
                         ":- query label :: 1; maxstep :: 1; 0: -p.")
    (h,) = d.solve("1", solutions=0).histories
    assert (h.value("p", 0), h.value("p", 1), h.value("a", 0)) == (False, True, False)
    assert d.format(d.solve("1")).split() == ["0:", "1:", "p"]
    # CCALC's transition mode would repeat a rule of step 1 at every later step: warned
    (w,) = d.diagnostics.items
    assert "CCALC in transition mode" in w.message and w.loc.line == 3


def test_a_time_stamped_fact_with_a_free_variable_holds_for_every_value():
    """Free variables of the head are universal: `0: -on(X).` darkens every lamp, and
    `1: on(X) where X \\= b.` causes on(a) at 1 whatever is done (as a condition it would have
    needed flip(a))."""
    src = """:- sorts lamp. :- objects a, b :: lamp. :- variables X :: lamp.
:- constants on(lamp) :: inertialFluent; flip(lamp) :: exogenousAction.
flip(X) causes on(X).
0: -on(X).
1: on(X) where X \\= b.
:- query maxstep :: 1; true."""
    r = histories(src)
    assert all(not h.value("on(a)", 0) and not h.value("on(b)", 0) for h in r.histories)
    assert all(h.value("on(a)", 1) for h in r.histories)
    assert len(r.histories) == 4 and {h.value("flip(a)", 0) for h in r.histories} == {True, False}


def test_a_body_variable_is_existential_and_a_false_head_condition_forbids():
    """`1: lit if 0: on(X).`: one rule per X, so lit is caused when some lamp is on; a head
    conjunct without constants that is false (`X \\= Y` for X = Y) makes a rule with head
    false (multiple-monkey-test's line: no history at all)."""
    src = """:- sorts lamp. :- objects a, b :: lamp. :- variables X, Y :: lamp.
:- constants on(lamp), lit :: inertialFluent.
1: lit if 0: on(X).
:- query maxstep :: 1; 0: -lit; 0: on(a) & -on(b)."""
    (h,) = histories(src).histories
    assert h.value("lit", 1)
    assert histories(src.replace("1: lit if 0: on(X).", "(0: on(X)) & (0: on(Y)) & X \\= Y.")).histories == []


def test_a_stamp_beyond_maxstep_leaves_that_rule_out():
    """CCALC grounds a rule only where its step exists: at maxstep 0, `(0: lit) & (1: -lit).`
    causes lit at 0 (one history); at maxstep 1 it also causes -lit at 1, so flip (which
    causes lit) is never done."""
    src = LAMP + "(0: lit) & (1: -lit).\n:- query maxstep :: 0..1; true.\n:- query label :: 1; maxstep :: 1; true."
    r = histories(src)
    assert r.maxstep == 0 and [h.value("lit", 0) for h in r.histories] == [True]
    (h,) = histories(src, "1").histories
    assert (h.value("lit", 0), h.value("lit", 1), h.value("flip", 0)) == (True, False, False)
    # an action at the last step does not exist either: `2: flip.` at maxstep 1 is left out
    assert len(histories(LAMP + "2: flip.\n:- query maxstep :: 1; true.").histories) == 4


def test_the_head_of_a_stamped_fact_is_a_literal():
    """CCALC: "One of the rules is not definite" for a head that is no conjunction of literals."""
    with pytest.raises(CPlusError, match="time-stamped fact is a literal") as exc:
        Domain.from_text(LAMP + "(1: lit) ->> (0: flip).")
    assert exc.value.loc.line == 3


def test_stamped_facts_are_in_the_dimacs_cnf(tmp_path):
    """`cplus ground --dimacs` writes D_m with the theory's stamped facts: its models are the
    histories `cplus plan -n 0` counts (2 at maxstep 1, not 4)."""
    from pysat.solvers import Solver
    f, cnf = tmp_path / "d.cp", tmp_path / "d.cnf"
    f.write_text(LAMP + "0: -lit.\n")
    out = subprocess.run([sys.executable, "-m", "cplus", "ground", str(f), "--maxstep", "1", "--dimacs", str(cnf)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    lines = cnf.read_text().splitlines()
    named = [int(x.split()[1]) for x in lines if x.startswith("c ") and len(x.split()) > 2 and x.split()[1].isdigit()]
    clauses = [[int(x) for x in ln.split()[:-1]] for ln in lines if ln and ln[0] not in "cp"]
    models = 0
    with Solver(bootstrap_with=clauses) as s:
        while s.solve():
            m = set(s.get_model())
            models += 1
            s.add_clause([-v if v in m else v for v in named])
    assert models == 2


def test_a_stamped_fact_takes_no_after_part():
    with pytest.raises(CPlusError, match="takes no 'after'") as exc:
        Domain.from_text(LAMP + "0: lit after flip.")
    assert exc.value.loc is not None and exc.value.loc.line == 3
