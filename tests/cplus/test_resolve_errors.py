"""Every error and warning the resolver (cplus/resolve/) can give, each with its exact text and
the place it points at (``file:line:col``), and the basic law each law form becomes.

A resolver check that no test reaches is a check a change could delete unnoticed; each row
here is one such check, reached by the smallest domain that trips it."""
from __future__ import annotations

import pytest

from cplus import ir
from cplus.errors import CPlusError, Diagnostics
from cplus.load import load_program, load_text

H = (":- sorts s. :- objects a, b :: s. :- variables X :: s; N :: 0..2.\n"
     ":- constants p(s), q :: inertialFluent; c :: inertialFluent(0..2); go(s) :: exogenousAction; "
     "r :: rigid; sd :: sdFluent; k :: s.\n")
"""Two lines of declarations; a case's own text starts on line 3."""
ADD = ":- maxAdditive :: 3. :- constants n :: additiveFluent(0..3); go :: exogenousAction.\n"
"""An additive fluent and an action on line 1; a case's text starts on line 2."""


def error(text: str) -> str:
    """The first error of a file: its loading's, or a query's that fails alone when asked."""
    with pytest.raises(CPlusError) as info:
        prog = load_text(text, "t.cp")
        for q in (*prog.queries, *prog.nmqueries):
            if q.error is not None:
                raise q.error
    return info.value.render().splitlines()[0]


def warnings(text: str) -> list[str]:
    d = Diagnostics()
    load_text(text, "t.cp", diagnostics=d)
    return [x.render().splitlines()[0] for x in d.items]


ERRORS = [
    # --- declarations: sorts and objects
    (":- sorts step.", "1:10", "'step' is a built-in name and cannot be declared as a sort"),
    (":- sorts inertialFluent.", "1:10", "'inertialFluent' is a built-in name and cannot be declared as a sort"),
    (":- sorts Big.", "1:10", "sort names start with a lower-case letter: 'Big'"),
    (":- sorts a. :- sorts a >> b; b >> a.", "1:35", "'b >> a' would make the sorts a cycle"),
    (":- objects a :: boolean.", "1:17", "the objects of 'boolean' are fixed (true, false)"),
    (":- objects a :: nosort.", "1:17", "unknown sort 'nosort'"),
    (":- sorts s. :- objects A :: s.", "1:24", "object names start with a lower-case letter: 'A'"),
    (":- constants p :: inertialFluent. :- sorts s. :- objects p :: s.", "1:58",
     "'p' is already declared as a constant"),
    (":- constants p(boolean) :: inertialFluent. :- sorts s. :- objects p(true) :: s.", "1:67",
     "'p/1' is already declared as a constant"),
    (":- sorts s; t. :- objects a :: s. :- objects f(nope) :: t.", "1:48", "'nope' is neither a sort nor an object"),
    (":- sorts s; t. :- objects f(p, q) :: t.", "1:29", "'p' is neither a sort nor an object"),
    (":- sorts s. :- objects 0..1999999 :: s.", "1:24",
     "the range 0..1999999 declares 2,000,000 objects; a domain may declare at most 1,000,000 objects in all"),
    (":- sorts s. :- objects n :: s. :- constants q :: inertialFluent. :- maxAdditive :: q.", "1:84",
     "expected an integer expression (numbers, macros and arithmetic only)"),
    # --- declarations: constants and variables
    (":- constants p :: fooFluent.", "1:19", "unknown constant kind or sort 'fooFluent'"),
    (":- sorts s. :- objects a :: s. :- constants n :: additiveFluent(s).", "1:50",
     "an additive constant needs a numeric domain; 's' has 'a'"),
    (":- constants x :: attribute of go.", "1:32", "unknown action 'go/0' in 'attribute ... of'"),
    (":- constants f :: inertialFluent; x :: attribute of f.", "1:53",
     "'f' is a inertialFluent; attributes belong to actions"),
    (":- sorts s. :- constants go(s) :: exogenousAction; x :: attribute of go(boolean).", "1:70",
     "the argument sorts of 'go' are (s)"),
    (":- sorts s. :- objects a :: s. :- constants go(s) :: exogenousAction; x(boolean) :: attribute of go(s).",
     "1:71", "the arguments of attribute 'x' must begin with those of 'go'"),
    (":- constants P :: inertialFluent.", "1:14", "constant names start with a lower-case letter: 'P'"),
    (":- constants p :: inertialFluent; p :: inertialFluent.", "1:35", "constant 'p/0' is declared twice"),
    (":- sorts s. :- objects p :: s. :- constants p :: inertialFluent.", "1:45", "'p' is already declared as an object"),
    (":- sorts s. :- objects f(1) :: s. :- constants f(s) :: inertialFluent.", "1:48",
     "'f' is already declared as an object"),
    (":- variables x :: boolean.", "1:14", "variable names start with an upper-case letter: 'x'"),
    (":- maxAdditive :: -1.", "1:4", "maxAdditive must not be negative"),
    (":- constants n :: additiveFluent(0..3).", "1:14", "additive constants need ':- maxAdditive :: N.'"),
    (":- sorts s. :- objects 0..999 :: s. :- constants p(s,s,s) :: inertialFluent.", "1:50",
     "'p/3' has 1,000,000,000 ground instances (1,000 x 1,000 x 1,000); a domain may have at most 1,000,000"),
    # --- sort expressions
    (":- constants c :: inertialFluent(0..n).", "1:37", "unknown name 'n'"),
    (":- constants c :: inertialFluent(0..100000000).", "1:34",
     "the range 0..100000000 has 100,000,001 integers; a range used as a sort may have at most 1,000,000"),
    (":- constants c :: inertialFluent(5..2).", "1:34", "empty range 5..2: a sort must have at least one object"),
    (":- constants c :: inertialFluent(foo(1)).", "1:34",
     "unknown constant kind or macro 'foo/1' (the kinds: abAction, action, additiveAction, additiveFluent, "
     "attribute, exogenousAction, inertialFluent, rigid, sdFluent, simpleFluent)"),
    (":- macros m(#1) -> #1 + 2. :- constants c :: inertialFluent(m(1)).", "1:61",
     "expected a sort: a sort name, 's*', 's+none' or a range 'lo..hi'"),
    (":- constants c :: inertialFluent(afValue).", "1:34", "'afValue' needs ':- maxAdditive :: N.' before it"),
    (":- constants c :: inertialFluent(nosort).", "1:34", "unknown sort 'nosort'"),
    # --- law classes and heads
    (H + " caused p(a) if q where c=1.", "3:2", "a 'where' condition may not mention constants"),
    (H + " caused go(a) after q.", "3:2", "a law with an action in its head cannot have an 'after' part"),
    (H + " caused q if go(a) after p(a).", "3:2",
     "the 'if' part of a law with 'after' may not mention actions (they belong in the 'after' part)"),
    (H + " caused r if q.", "3:2", "a law with a rigid constant in its head may mention only rigid constants"),
    (H + " caused r after q.", "3:2", "'r' is a rigid; it cannot be the head of a law with 'after'"),
    (H + " caused q if go(a).", "3:2",
     "a static law's 'if' part may not mention actions; use 'after', 'always' or 'nonexecutable'"),
    (H + " caused r if sd.", "3:2", "a law with a rigid constant in its head may mention only rigid constants"),
    (H + ":- variables F :: inertialFluent. caused F & sd after q.", "3:35",
     "'sd' is a sdFluent; it cannot be the head of a law with 'after'"),
    (":- constants q :: inertialFluent; go :: exogenousAction; fast :: attribute of go.\ncaused -fast if go.", "2:1",
     "a negated non-Boolean atom -(c=v) cannot be a head; the causal theory would not be definite"),
    (H + "caused q if c = max(1, 2, 0).", "3:17", "unknown constant or function 'max/3'"),
    (H + " caused q & go(a).", "3:2", "a law's head may not mix actions and fluents"),
    (H + " go(a) causes p(a) & go(b).", "3:2", "a law's head may not mix actions and fluents"),
    (H + " go(a) causes q after p(a).", "3:2", "'causes' takes no 'after' part"),
    (H + " go(a) causes go(b) after q.", "3:2", "'causes' takes no 'after' part"),
    (H + " go(a) may cause q after p(a).", "3:2", "'may cause' takes no 'after' part"),
    (H + " nonexecutable go(a) after p(a).", "3:2", "'nonexecutable' takes no 'after' part"),
    (H + " constraint go(a).", "3:2", "'constraint' cannot mention actions; use 'always' or 'nonexecutable'"),
    (H + " always q if p(a).", "3:2", "'always F' takes no 'if' part"),
    (H + " 0: q after p(a).", "3:2",
     "a time-stamped fact takes no 'after' or 'unless' part (its stamps name its steps)"),
    (H + " 0: q unless ab.", "3:2",
     "a time-stamped fact takes no 'after' or 'unless' part (its stamps name its steps)"),
    (H + " 0: q where c=X.", "3:2", "a 'where' condition may not mention constants"),
    (H + " caused --q.", "3:2", "a doubly negated head '--F' is Cplus2ASP's choice ('F may hold'); CCALC has no "
     "such head: write 'default F' (with the same 'if'/'after' parts)"),
    (H + " caused q ++ p(a).", "3:2", "the head of this law is not a literal or conjunction of literals (found a "
     "disjunction); the causal theory would not be definite"),
    (H + " caused q ->> p(a).", "3:2", "the head of this law is not a literal or conjunction of literals (found an "
     "implication); the causal theory would not be definite"),
    (H + " caused -(c=1).", "3:2", "a negated non-Boolean atom -(c=v) cannot be a head; "
     "the causal theory would not be definite"),
    (H + " caused sd after q.", "3:2", "'sd' is a sdFluent; it cannot be the head of a law with 'after'"),
    (ADD + "caused n=1.", "2:1", "'n' is additive; it changes only by 'increments'/'decrements' laws"),
    # --- unless
    (H + " caused q unless q & q.", "3:18", "'unless' takes an abnormality atom ab(args)"),
    (H + " caused q unless X.", "3:18", "'unless' takes an abnormality atom ab(args)"),
    (H + " caused q unless c.", "3:18", "'c' in 'unless' must be Boolean"),
    (H + " caused q unless Xy.", "3:18", "'unless' takes an abnormality atom ab(args)"),
    (H + " caused q unless ab(N+1).", "3:18", "the arguments of an undeclared abnormality must be variables or objects"),
    # --- frame laws
    (H + " inertial q & -p(a).", "3:15", "'inertial' takes constants, e.g. 'inertial c(X)'"),
    (H + " exogenous q, 3.", "3:15", "'exogenous' takes constants, e.g. 'exogenous c(X)'"),
    (H + " inertial abs(X).", "3:15", "arithmetic on variable X of sort 's', which has no integers"),
    (H + " inertial p(k).", "3:11", "the arguments of 'p' in 'inertial' may not mention constants"),
    (H + " exogenous q after p(a).", "3:2", "'exogenous c' takes no 'after' part"),
    (H + " inertial go(a).", "3:11", "'inertial' applies to fluents; 'go' is a exogenousAction"),
    (H + " rigid r.", "3:8", "'rigid' applies to fluents; 'r' is a rigid"),
    (H + " inertial sd.", "3:11", "'inertial' cannot apply to the sdFluent 'sd'"),
    (ADD + "inertial n.", "2:10", "'inertial' cannot apply to the additiveFluent 'n'"),
    # --- increments
    (H + " go(a) increments q by 1.", "3:19", "'increments'/'decrements' apply to additive constants"),
    (":- sorts s. :- objects a :: s. :- maxAdditive :: 3. :- constants n(s) :: additiveFluent(0..3); k :: s; "
     "go :: exogenousAction.\ngo increments n(k) by 1.", "2:15",
     "the arguments of 'n' in 'increments' may not mention constants"),
    (ADD + ":- constants q :: inertialFluent. q increments n by 1.", "2:35",
     "the left side of 'increments' must be an action"),
    (ADD + ":- constants m :: inertialFluent(0..3). go increments n by m.", "2:60",
     "the amount of 'increments' may not mention constants"),
    (ADD + "go increments n by 1 after go.", "2:1", "'increments' takes no 'after' part"),
    (ADD + "go increments n by 1 unless n.", "2:29", "'n' in 'unless' must be Boolean"),
    # --- formulas
    (H + "caused q if 1..2.", "3:13", "a range 'lo..hi' may only occur in declarations (objects, the sorts of "
     "constants and variables, macros used there) and in 'maxstep ::'"),
    (H + ":- query maxstep :: 0; 0: p(s*).", "3:29", "the sort 's*' may only occur in declarations"),
    (H + "caused q if go(a) & c+1.", "3:21", "expected a formula, found an arithmetic term ('+')"),
    (H + "caused q if -c.", "3:14", "'c' is not Boolean (its domain is 0..2); write c(...)=value"),
    (H + "caused q if abs(c).", "3:13", "expected a formula, found an arithmetic term"),
    (H + ":- query 0: q; 3.", "3:16", "expected a formula, found the number 3"),
    (H + "caused 0: q.", "3:8", "time stamps 'i: ...' may only occur in queries"),
    (H + "caused q if 0: q.", "3:13", "time stamps 'i: ...' may only occur in queries"),
    (H + "caused q if maxstep.", "3:13", "expected a formula, found 'maxstep'"),
    (H + "caused q if #1.", "3:13", "macro parameter #1 outside a macro body"),
    (H + "caused q if c=3.", "3:13", "'3' is not in the domain 0..2 of 'c'"),
    (H + "caused q if X.", "3:13", "variable X of sort 's' is not a formula"),
    (H + "caused q if a.", "3:13", "expected a formula, found the object 'a'"),
    (H + "caused q if [\\/Y | p(Y)].", "3:16", "unknown variable 'Y' in a quantifier"),
    (":- variables T :: step. :- constants q :: inertialFluent. caused q if [\\/T | q].", "1:74",
     "variables over steps may only occur in queries"),
    (":- sorts s; t. :- objects a :: s; b :: t. :- variables X :: s. :- constants p(t) :: inertialFluent.\n"
     "caused p(X).", "2:10", "variable X of sort 's' can never be an argument of sort 't' of 'p'"),
    (H + "caused p(1).", "3:8", "'1' is not an object of sort 's' (argument of 'p')"),
    # --- terms
    (H + "caused q if X(a).", "3:13", "'X' looks like a variable but has arguments"),
    (H + "caused q if Z.", "3:13", "unknown variable 'Z' (declare it in ':- variables')"),
    (H + "caused q if p.", "3:13", "constant 'p' takes 1 argument(s), not 0"),
    (H + "caused q if p(a, b).", "3:13", "constant 'p' takes 1 argument(s), not 2"),
    (H + "caused q if s.", "3:13", "'s' is a sort, not an object or constant"),
    (H + "caused q if zz(a).", "3:13", "unknown constant or function 'zz/1'"),
    (H + "caused q if zz.", "3:13", "unknown name 'zz'"),
    (H + "caused q if c = abs(a).", "3:17", "arithmetic on the object 'a' (not an integer)"),
    (H + "caused q if c = (q & q).", "3:18", "expected a term, found a formula ('&')"),
    (H + "caused q if c = -(1 & 2).", "3:19", "expected a term, found a formula ('&')"),
    (H + "caused q if c = maxstep.", "3:17", "'maxstep' may only occur in queries"),
    (H + "caused q if c = [\\/X | p(X)].", "3:17", "expected a term, found a quantified formula"),
    (H + "caused q if c = 9223372036854775807 + 1.", "3:17",
     "the value of this expression, 9,223,372,036,854,775,808, is outside the integers (-2^63..2^63-1)"),
    (H + "caused q if c = -9223372036854775807 - 2.", "3:17",
     "the value of this expression, -9,223,372,036,854,775,809, is outside the integers (-2^63..2^63-1)"),
    (H + "caused q if c = 1 // 0.", "3:17", "division by zero"),
    (H + "caused q if c = X + 1.", "3:17", "arithmetic on variable X of sort 's', which has no integers"),
    (H + "caused q if -k = a.", "3:13", "'-k' before a comparison is arithmetic minus in CCALC ('(-k)=...'), and "
     "'k' has no integer values (CCALC: Invalid expression); write '-(k=...)' for the negation"),
    (H + "caused q if -q = true.", "3:13", "'-q' before a comparison is arithmetic minus in CCALC ('(-q)=...'), and "
     "'q' has no integer values (CCALC: Invalid expression); write '-(q=...)' for the negation"),
    (H + "caused q if -a = k.", "3:13", "'-a' before a comparison is arithmetic minus in CCALC ('(-a)=...'), and "
     "'a' has no integer values (CCALC: Invalid expression); write '-(a=...)' for the negation"),
    (H + "caused q if -X = k.", "3:13", "'-X' before a comparison is arithmetic minus in CCALC ('(-X)=...'), and "
     "'X' has no integer values (CCALC: Invalid expression); write '-(X=...)' for the negation"),
    (":- sorts s. :- objects f(1..2) :: s. :- constants v :: s. caused v = f(3).", "1:70",
     "'f(3)' is not a declared object"),
    (H + "caused q if c = var(a(1), 1).", "3:17", "var(s, k) needs a sort name s"),
    # --- queries
    (H + ":- query label :: a; label :: b.", "3:22", "a query has at most one label"),
    (H + ":- query maxstep :: 1; maxstep :: 2.", "3:24", "a query has at most one maxstep"),
    (H + ":- query maxstep :: -1..2.", "3:10", "malformed maxstep -1..2: need 0 =< min =< max"),
    (H + ":- query maxstep :: 3..2.", "3:10", "malformed maxstep 3..2: need 0 =< min =< max"),
    (H + ":- query maxstep :: aa.", "3:21", "unknown name 'aa'"),              # 'any' is that word only
    (H + ":- macros r -> 1..3. :- query maxstep :: r..5.", "3:16", "a range 'lo..hi' may only occur in declarations "
     "(objects, the sorts of constants and variables, macros used there) and in 'maxstep ::'"),
    (H + ":- query maxstep :: any; invariant: q; invariant: q.", "3:40", "a query has at most one invariant"),
    (H + ":- nmquery label :: 1; caused 0: q ++ q.", "3:24",
     "the head of an nmquery rule is a literal ('t: c=v', 't: p', 't: -p'), a conjunction of them, or false: "
     "anything else makes the rules non-definite"),
    (H + ":- nmquery label :: 1; caused 0: -(c=1).", "3:24",
     "the head of an nmquery rule is a literal ('t: c=v', 't: p', 't: -p'), a conjunction of them, or false: "
     "anything else makes the rules non-definite"),
    # --- show
    (H + ":- show 3.", "3:9", "a show/hide pattern is an atom 'c(args)' or 'c(args)=v'"),
    (H + ":- hide 3.", "3:9", "a show/hide pattern is an atom 'c(args)' or 'c(args)=v'"),
    (H + ":- show zz.", "3:9", "unknown constant 'zz/0' in show/hide"),
    (H + ":- show p(c).", "3:11", "show/hide arguments are objects or variables"),
    (H + ":- show q=q.", "3:11", "show/hide arguments are objects or variables"),
    # --- macros and includes
    (H + ":- macros m(#1) -> #2. caused q if m(1).", "3:20", "macro parameter #2 has no argument"),
    (":- macros m(#1) -> m(m(#1)). :- constants q :: inertialFluent. caused q if m(1).", "1:22",
     "recursive macro 'm/1'"),
    (":- include 'nowhere.cp'.", "1:12", "cannot find included file 'nowhere.cp'"),
    # --- a law put off for a later declaration is reported before the statement that fails
    (":- constants q :: inertialFluent. caused q if r. :- constants r :: inertialFluent. caused zz.", "1:91",
     "unknown name 'zz'"),
    (":- constants q :: inertialFluent. caused q if r. :- constants r :: inertialFluent. caused q if r2.\n"
     ":- constants c :: inertialFluent(0..1). caused c=3.", "1:96", "unknown name 'r2'"),
    (":- constants q :: inertialFluent. caused q if r.", "1:47", "unknown name 'r'"),
]


@pytest.mark.parametrize("text, where, message", ERRORS, ids=[m[:60] for _, _, m in ERRORS])
def test_each_resolver_error_is_located(text, where, message):
    assert error(text) == f"t.cp:{where}: error: {message}"


WARNINGS = [
    (":- sorts n. :- objects 5..2, 7 :: n.", ["t.cp:1:24: warning: the range 5..2 is empty: it declares no objects"]),
    (":- sorts n. :- objects 2..2 :: n.", []),
    (H + "caused q if -c = 1.", ["t.cp:3:13: warning: '-c' before a comparison means '(-c)' in CCALC (minus binds "
                                "tighter than '='): '-c=v' says c = -v; write '-(c=v)' for 'c is not v'"]),
    (H + "0: c = 0. 0: c = 2.", []),
    (H + "caused q if c \\= 2 & c \\= 0.", []),
    (H + ":- query label :: 1. :- query label :: 1.",
     ["t.cp:3:25: warning: query label '1' is used again; as in CCALC the first query with this label is the one "
      "answered, this one is ignored"]),
    (H + ":- nmquery label :: 1. :- nmquery label :: 1.",
     ["t.cp:3:27: warning: nmquery label '1' is used again; as in CCALC the first nmquery with this label is the "
      "one answered, this one is ignored"]),
    (H + ":- query label :: 1. :- nmquery label :: 1.", []),
    (":- constants positive :: inertialFluent. :- show positive.",
     ["t.cp:1:50: warning: show specification 'positive' is ambiguous: it is a keyword of ':- show', so it does "
      "not name the constant 'positive' (write 'positive=V' or give its arguments for the constant)"]),
    (":- constants q :: inertialFluent. :- show positive.", []),
]


@pytest.mark.parametrize("text, expected", WARNINGS)
def test_each_resolver_warning_is_located(text, expected):
    assert warnings(text) == expected


def test_includes_are_read_relative_to_the_including_file(tmp_path, monkeypatch):
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "a.cp").write_text(":- include 'b.cp'.", encoding="utf-8")
    (tmp_path / "sub" / "b.cp").write_text(":- constants q :: inertialFluent.", encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert load_text(":- include 'sub/a.cp'.").signature.lookup("q", 0) is not None


def test_the_first_query_of_a_label_is_the_one_kept():
    """CCALC answers the first query_problem of a label (ccalc.pl, query/2)."""
    prog = load_text(H + ":- query label :: 2; 0: q. :- query label :: 1; 0: q. :- query label :: 1; 0: -q.")
    assert [(q.label, [show(f) for f, _ in q.items]) for q in prog.queries] == [
        ("2", ["0:q=true"]), ("1", ["0:q=true"])]


def test_a_stamped_fact_outside_its_constants_domain_is_an_error_as_a_laws_head():
    with pytest.raises(CPlusError) as exc:
        load_text(H + "0: c = 3.", "t.cp")
    assert str(exc.value) == "t.cp:3:4: '3' is not in the domain 0..2 of 'c'"


def test_a_query_without_maxstep_is_at_maxstep_0():
    (q,) = load_text(H + ":- query label :: g; 0: q.").queries
    assert (q.label, q.lo, q.hi) == ("g", 0, 0)
    (q,) = load_text(H + ":- query maxstep :: 2..4.").queries
    assert (q.label, q.lo, q.hi) == ("0", 2, 4)
    (q,) = load_text(H + ":- macros r -> 1..3. :- query maxstep :: r.").queries
    assert (q.lo, q.hi) == (1, 3)


def test_show_and_hide_patterns():
    prog = load_text(":- constants p(boolean), q :: inertialFluent. :- show -q; p. :- hide q=true.")
    assert [(pt.name, pt.args, pt.value, pt.negated, pt.decl is None) for pt in prog.show] == [
        ("q", (), None, True, False), ("p", (), None, False, True)]
    assert [(pt.name, pt.value, pt.negated) for pt in prog.hide] == [("q", "true", False)]
    assert prog.show_given and not prog.hide_all
    prog = load_text(":- constants q :: inertialFluent. :- hide all.")
    assert prog.hide_all and not prog.show_given


def test_between_is_inclusive():
    from cplus.resolve.registry import BUILTIN_EXTERNALS
    between = BUILTIN_EXTERNALS.get("between", 3).fn
    assert [x for x in range(-1, 5) if between(1, 3, x)] == [1, 2, 3]
    assert not between(1, 3, "a") and not between("a", 3, 2)


def test_an_error_in_an_included_file_names_that_file(tmp_path):
    (tmp_path / "part.cp").write_text(":- constants q :: inertialFluent.\ncaused zz.", encoding="utf-8")
    (tmp_path / "main.cp").write_text(":- include 'part'.\n", encoding="utf-8")
    with pytest.raises(CPlusError) as info:
        load_program(str(tmp_path / "main.cp"))
    assert info.value.render().splitlines()[0] == f"{tmp_path / 'part.cp'}:2:8: error: unknown name 'zz'"


def test_a_file_included_twice_is_read_once(tmp_path):
    (tmp_path / "part.cp").write_text(":- constants q :: inertialFluent.", encoding="utf-8")
    (tmp_path / "main.cp").write_text(":- include 'part.cp'. :- include 'part.cp'; 'part'.", encoding="utf-8")
    prog = load_program(str(tmp_path / "main.cp"))
    assert [d.name for d in prog.signature.constants.values()] == ["q"]


def test_includes_nest_to_a_bound(tmp_path):
    for i in range(70):
        (tmp_path / f"f{i}.cp").write_text(f":- include 'f{i + 1}.cp'.", encoding="utf-8")
    (tmp_path / "f70.cp").write_text(":- constants q :: inertialFluent.", encoding="utf-8")
    with pytest.raises(CPlusError) as info:
        load_program(str(tmp_path / "f0.cp"))
    assert info.value.render().splitlines()[0] == f"{tmp_path / 'f64.cp'}:1:12: error: includes nested too deeply"
    (tmp_path / "f64.cp").write_text(":- constants q :: inertialFluent.", encoding="utf-8")
    assert load_program(str(tmp_path / "f0.cp")).signature.lookup("q", 0) is not None


# --------------------------------------------------------------------------- limits, at their boundary

def test_objects_up_to_the_limit(monkeypatch):
    import cplus.resolve.declarations as declarations
    monkeypatch.setattr(declarations, "MAX_OBJECTS", 10)   # true, false and 8 more
    assert len(load_text(":- sorts s. :- objects 1..4, 5..8 :: s.").signature.sorts["s"].objects) == 8
    assert error(":- sorts s. :- objects 1..9 :: s.") == (
        "t.cp:1:24: error: the range 1..9 declares 9 objects; a domain may declare at most 10 objects in all")
    assert error(":- sorts s. :- objects 1..4, 5..9 :: s.") == (
        "t.cp:1:30: error: the range 5..9 declares 5 objects; a domain may declare at most 10 objects in all "
        "(6 are declared already)")
    assert error(":- sorts s. :- objects a, b :: s. :- objects 5..12 :: s.") == (
        "t.cp:1:46: error: the range 5..12 declares 8 objects; a domain may declare at most 10 objects in all "
        "(4 are declared already)")
    assert error(":- sorts s; t. :- objects 1..3 :: s. :- objects f(s, s) :: t.") == (
        "t.cp:1:49: error: 'f(...)' declares 9 objects; a domain may declare at most 10 objects in all "
        "(5 are declared already)")
    two = load_text(":- sorts s; t. :- objects 1..2 :: s. :- objects f(s, s) :: t.")
    assert len(two.signature.sorts["t"].objects) == 4


def test_ground_constants_up_to_the_limit(monkeypatch):
    import cplus.resolve.core as core
    monkeypatch.setattr(core, "MAX_GROUND_CONSTANTS", 12)
    ok = ":- sorts s. :- objects 1..3 :: s. :- constants p(s, s) :: inertialFluent; q(s) :: inertialFluent."
    assert load_text(ok).signature.lookup("q", 1) is not None            # 9 + 3 = 12
    assert error(ok + " :- constants z :: inertialFluent.") == (
        "t.cp:1:112: error: 'z/0' has 1 ground instances (), 13 with the constants before it; "
        "a domain may have at most 12")


def test_range_sorts_up_to_the_limit(monkeypatch):
    import cplus.resolve.terms as terms
    monkeypatch.setattr(terms, "MAX_RANGE", 5)
    assert load_text(":- constants c :: inertialFluent(1..5).").signature.lookup("c", 0) is not None
    assert error(":- constants c :: inertialFluent(1..6).") == (
        "t.cp:1:34: error: the range 1..6 has 6 integers; a range used as a sort may have at most 5")
    assert load_text(":- constants c :: inertialFluent(3..3).").signature.lookup("c", 0) is not None


def test_nesting_below_the_limit_is_measured_level_by_level():
    base = ":- constants c :: inertialFluent(0..9). :- macros m(#1) -> #1 + 0.\n"
    assert warnings(base + "caused c = max(1, 1+(1+(1+(1+(1+(1+(1+(1+0)))))))).") == []


def test_af_value_is_0_to_max_additive():
    prog = load_text(":- maxAdditive :: 2. :- constants c :: inertialFluent(afValue).")
    assert list(prog.signature.objects_of(prog.signature.lookup("c", 0).domain)) == [0, 1, 2]


def test_integers_up_to_the_limit():
    top = H + "caused q if c = 9223372036854775806 + 1 - 9223372036854775807."
    assert warnings(top) == []
    bottom = H + "caused q if c = -9223372036854775807 - 1 + 9223372036854775807 + 1."
    assert warnings(bottom) == []


def test_macro_expansion_up_to_the_limits(monkeypatch):
    import cplus.resolve.macros as macros
    base = ":- constants c :: inertialFluent(0..9). :- macros m(#1) -> #1 + #1.\n"
    monkeypatch.setattr(macros, "MAX_EXPANSION", 9)
    assert warnings(base + "caused c = m(m(1)).") == []                   # c = ((1+1)+(1+1)): 9 nodes
    assert error(base + "caused c = m(m(1)) + 1.") == (
        "t.cp:2:8: error: expanding the macros here gives an expression of 11 nodes; the limit is 9")
    monkeypatch.setattr(macros, "MAX_EXPANSION", 50_000)
    monkeypatch.setattr(macros, "MAX_NESTING", 4)
    deep = ":- constants c :: inertialFluent(0..9). :- macros m(#1) -> #1 + 0.\n"
    assert warnings(deep + "caused c = m(m(1)).") == []
    assert error(deep + "caused c = m(m(m(1))).") == (
        "t.cp:2:8: error: expanding the macros here nests expressions (or macro calls) more than 4 levels deep")
    assert warnings(deep + "caused c = max(1, max(1, 1)).") == []       # a function's arguments nest too
    assert error(deep + "caused c = max(1, max(1, max(1, 1))).") == (
        "t.cp:2:8: error: expanding the macros here nests expressions (or macro calls) more than 4 levels deep")
    monkeypatch.setattr(macros, "MAX_NESTING", 5)       # past the limit the walk stops: still refused
    assert error(deep + "caused c = m(m(m(m(m(m(m(1))))))).") == (
        "t.cp:2:8: error: expanding the macros here nests expressions (or macro calls) more than 5 levels deep")
    monkeypatch.setattr(macros, "MAX_NESTING", 100)
    monkeypatch.setattr(macros, "MAX_EXPANSION", 8)
    assert warnings(deep + "caused c = max(1, max(1, 1)).") == []       # 7 nodes
    assert error(deep + "caused c = max(1, max(1, max(1, 1))).") == (
        "t.cp:2:8: error: expanding the macros here gives an expression of 9 nodes; the limit is 8")
    two = ":- constants c :: inertialFluent(0..9). :- macros m2(#1, #2) -> #1 + 0.\n"   # each parameter its size
    assert warnings(two + "caused c = m2(1, max(1, max(1, max(1, 1)))).") == []
    assert error(two + "caused c = m2(max(1, max(1, max(1, 1))), 0).") == (
        "t.cp:2:8: error: expanding the macros here gives an expression of 11 nodes; the limit is 8")
    monkeypatch.setattr(macros, "MAX_EXPANSION", 50_000)
    monkeypatch.setattr(macros, "MAX_EXPANDED", 20)
    many = base + "caused c = m(1).\ncaused c = m(1).\ncaused c = m(1).\n"     # 5 nodes each
    assert warnings(many + "caused c = 1 + 1 + 1.\ncaused c = m(1).") == []  # no macro: not counted; 20 in all
    assert error(many + "caused c = m(1).\ncaused c = m(1).") == (
        "t.cp:6:8: error: macro expansion has produced more than 20 nodes in this domain, the limit "
        "(this is where it went over)")


# --------------------------------------------------------------------------- what each law form becomes

def show(f) -> str:
    """A basic law's formula as text, fully bracketed."""
    if f is None:
        return "-"
    if isinstance(f, ir.Truth):
        return "true" if f.value else "false"
    if isinstance(f, ir.Atom):
        return f"{show(f.cst)}={show(f.value)}"
    if isinstance(f, ir.Cst):
        return f.decl.name + (f"({','.join(show(a) for a in f.args)})" if f.args else "")
    if isinstance(f, ir.Lit):
        return str(f.value)
    if isinstance(f, ir.Var):
        return f.name
    if isinstance(f, ir.Not):
        return f"-{show(f.arg)}"
    if isinstance(f, ir.And):
        return "(" + " & ".join(show(x) for x in f.items) + ")"
    if isinstance(f, ir.Or):
        return "(" + " ++ ".join(show(x) for x in f.items) + ")"
    if isinstance(f, ir.Cmp):
        return f"{show(f.left)}{f.op}{show(f.right)}"
    if isinstance(f, ir.Arith):
        return f"{f.op}({','.join(show(a) for a in f.args)})"
    if isinstance(f, ir.Quant):
        return f"[{'E' if f.exists else 'A'}{f.var.name}:{f.var.sort} | {show(f.body)}]"
    if isinstance(f, ir.StampF):
        return f"{show(f.time)}:{show(f.body)}"
    if isinstance(f, ir.Imp):
        return f"({show(f.left)} ->> {show(f.right)})"
    raise TypeError(f)


def laws(text: str) -> list[str]:
    prog = load_text(H + text)
    return [f"{law.cls} {law.origin}: {show(law.head)} | {show(law.body)} | {show(law.after)} | {show(law.where)}"
            + (f" [{law.frame} {show(law.frame_cst)}]" if law.frame else "") for law in prog.laws]


@pytest.mark.parametrize("text, expected", [
    ("caused q.", ["static caused: q=true | true | - | -"]),
    ("caused q if p(a).", ["static caused: q=true | p(a)=true | - | -"]),
    ("caused q if p(a) after go(a).", ["dynamic caused: q=true | p(a)=true | go(a)=true | -"]),
    ("caused false if q.", ["static caused: - | q=true | - | -"]),
    ("caused -true if q.", ["static caused: - | q=true | - | -"]),
    ("caused -false.", []),
    ("caused true if q.", []),
    ("caused r if r.", ["rigid caused: r=true | r=true | - | -"]),
    ("caused go(a) if go(b).", ["action caused: go(a)=true | go(b)=true | - | -"]),
    ("caused q if p(X) where X = a.", ["static caused: q=true | p(X)=true | - | X=a"]),
    ("default q.", ["static default: q=true | q=true | - | -"]),
    ("default q if p(a).", ["static default: q=true | (q=true & p(a)=true) | - | -"]),
    ("default q after p(a).", ["dynamic default: q=true | q=true | p(a)=true | -"]),
    ("default -go(a).", ["action default: -go(a)=true | -go(a)=true | - | -"]),
    ("go(a) causes q.", ["dynamic causes: q=true | true | go(a)=true | -"]),
    ("go(a) causes q if p(a).", ["dynamic causes: q=true | true | (go(a)=true & p(a)=true) | -"]),
    ("go(a) causes go(b).", ["action causes: go(b)=true | go(a)=true | - | -"]),
    ("go(a) causes go(b) if q.", ["action causes: go(b)=true | (go(a)=true & q=true) | - | -"]),
    ("go(a) may cause q if p(a).", ["dynamic may cause: q=true | q=true | (go(a)=true & p(a)=true) | -"]),
    ("nonexecutable go(a) if q.", ["dynamic nonexecutable: - | true | (go(a)=true & q=true) | -"]),
    ("nonexecutable go(a).", ["dynamic nonexecutable: - | true | go(a)=true | -"]),
    ("constraint q.", ["static constraint: - | -q=true | - | -"]),
    ("constraint q if p(a).", ["static constraint: - | (-q=true & p(a)=true) | - | -"]),
    ("constraint q after go(a).", ["dynamic constraint: - | -q=true | go(a)=true | -"]),
    ("constraint r.", ["rigid constraint: - | -r=true | - | -"]),
    ("always q.", ["dynamic always: - | true | -q=true | -"]),
    ("always q after p(a).", ["dynamic always: - | true | (-q=true & p(a)=true) | -"]),
    ("never q.", ["static never: - | q=true | - | -"]),
    ("never q if p(a).", ["static never: - | (q=true & p(a)=true) | - | -"]),
    ("never go(a).", ["action never: - | go(a)=true | - | -"]),
    (":- constants ac :: action. caused -ac if q.", ["action caused: -ac=true | q=true | - | -"]),
    (":- variables A :: exogenousAction. caused go(a) if A = true. caused go(a) if A \\= true.",
     ["action caused: go(a)=true | A=true | - | -", "action caused: go(a)=true | -A=true | - | -"]),
    ("caused q if [\\/var(s,1) | p(var(s,1))].", ["static caused: q=true | [Evar(s,1):s | p(var(s,1))=true] | - | -"]),
    (":- macros m -> a. caused p(m).", ["static caused: p(a)=true | true | - | -"]),
    (":- macros m(#1) -> #1. caused p(m(b)) if c = m(2).", ["static caused: p(b)=true | c=2 | - | -"]),
    ("caused c = max(1, 2). caused c = min(1, 2).", ["static caused: c=2 | true | - | -",
                                                     "static caused: c=1 | true | - | -"]),
    ("caused q & -p(a).", ["static caused: (q=true & -p(a)=true) | true | - | -"]),
    ("caused q & true.", ["static caused: q=true | true | - | -"]),
    ("caused q & -false.", ["static caused: q=true | true | - | -"]),
    ("caused q & -true.", ["static caused: (q=true & false) | true | - | -"]),
    # frame laws
    ("inertial q.", ["dynamic inertial: - | true | true | - [inertial q]"]),
    ("inertial q if p(a).", ["dynamic inertial: - | true | p(a)=true | - [inertial q]"]),
    ("inertial q after go(a).", ["dynamic inertial: - | true | go(a)=true | - [inertial q]"]),
    ("inertial q if p(a) after go(a).", ["dynamic inertial: - | true | (go(a)=true & p(a)=true) | - [inertial q]"]),
    ("inertial q, p(a).", ["dynamic inertial: - | true | true | - [inertial q]",
                           "dynamic inertial: - | true | true | - [inertial p(a)]"]),
    ("inertial p(X) where X = a.", ["dynamic inertial: - | true | true | X=a [inertial p(X)]"]),
    ("rigid q if p(a).", ["dynamic rigid: - | p(a)=true | true | - [rigid q]"]),
    ("rigid q if p(a) after p(b).", ["dynamic rigid: - | p(a)=true | p(b)=true | - [rigid q]"]),
    ("exogenous q.", ["static exogenous: - | true | - | - [exogenous q]"]),
    ("exogenous q if p(a).", ["static exogenous: - | p(a)=true | - | - [exogenous q]"]),
    ("exogenous go(a).", ["action exogenous: - | true | - | - [exogenous go(a)]"]),
    ("exogenous r.", ["rigid exogenous: - | true | - | - [exogenous r]"]),
    # unless: an undeclared abnormality is declared; the first unless naming a constant gives
    # it `default -ab` (macros.std), declared or not
    ("go(a) causes q unless ab(X).", ["action default: -ab(_ab0)=true | -ab(_ab0)=true | - | -", "dynamic causes: q=true | true | (go(a)=true & -ab(X)=true) | -"]),
    ("caused q after go(a) unless ab(a).", ["action default: -ab(_ab0)=true | -ab(_ab0)=true | - | -", "dynamic caused: q=true | true | (go(a)=true & -ab(a)=true) | -"]),
    ("caused go(a) if q unless ab(1).", ["action default: -ab(_ab0)=true | -ab(_ab0)=true | - | -", "action caused: go(a)=true | (q=true & -ab(1)=true) | - | -"]),
    ("caused q if p(a) unless sab(a).", ["static default: -sab(_ab0)=true | -sab(_ab0)=true | - | -",
                                         "static caused: q=true | (p(a)=true & -sab(a)=true) | - | -"]),
    ("caused r unless rab.", ["rigid default: -rab=true | -rab=true | - | -",
                              "rigid caused: r=true | -rab=true | - | -"]),
    ("caused q if -(N+1) = 2 - 5.", ["static caused: q=true | +(neg(N),1)=-3 | - | -"]),   # CCALC's minus
    ("caused q unless abC.", ["static default: -abC=true | -abC=true | - | -",
                              "static caused: q=true | -abC=true | - | -"]),
    ("caused q unless p(a).", ["static default: -p(_ab0)=true | -p(_ab0)=true | - | -", "static caused: q=true | -p(a)=true | - | -"]),
    ("inertial q unless ab(a).", ["action default: -ab(_ab0)=true | -ab(_ab0)=true | - | -", "dynamic inertial: - | true | -ab(a)=true | - [inertial q]"]),
    ("exogenous q unless sab2.", ["static default: -sab2=true | -sab2=true | - | -",
                                  "static exogenous: - | -sab2=true | - | - [exogenous q]"]),
])
def test_each_law_form_becomes_its_basic_law(text, expected):
    assert laws(text) == expected


def test_an_undeclared_abnormality_takes_the_sorts_of_its_arguments():
    prog = load_text(H + "go(X) causes q unless ab(X, b, 1).")
    decl = prog.signature.lookup("ab", 3)
    assert (decl.kind, [str(s) for s in decl.argsorts], str(decl.domain), decl.auto_ab) == (
        "abAction", ["s", "s", "1..1"], "boolean", True)


def test_increments_become_increment_laws():
    prog = load_text(ADD + ":- constants q :: inertialFluent.\ngo increments n by 2 if q unless ab.\n"
                     "go decrements n by 1.")
    got = [(show(i.action), show(i.target), show(i.amount), show(i.cond), i.decrement) for i in prog.increments]
    assert got == [("go=true", "n", "2", "(q=true & -ab=true)", False), ("go=true", "n", "1", "true", True)]


def test_a_time_stamped_fact_is_a_causal_rule_of_its_step():
    """CCALC: `caused q` at step 0 when the body holds, through a hidden fluent (StampedRule)
    that is the body at that step; a variable of the body alone is existential."""
    prog = load_text(H + "0: q if 1: p(a) where X = a.\n0: -q.")
    assert [(r.cst.decl.name, r.step, show(r.body)) for r in prog.facts] == [
        ("fact#1", 0, "[EX:s | (X=a & 1:p(a)=true)]"), ("fact#2", 0, "true")]
    assert laws_of(prog) == ["static fact: q=true | fact#1=true | - | -", "static exogenous: - | true | - | -",
                             "static fact: -q=true | fact#2=true | - | -", "static exogenous: - | true | - | -"]
    assert all(r.cst.decl.hidden for r in prog.facts)


def test_a_declaration_after_the_law_that_names_it_is_found():
    prog = load_text(":- constants q :: inertialFluent. caused q if r. :- constants r :: inertialFluent.")
    assert laws_of(prog) == ["static caused: q=true | r=true | - | -"]


def laws_of(prog) -> list[str]:
    return [f"{law.cls} {law.origin}: {show(law.head)} | {show(law.body)} | {show(law.after)} | {show(law.where)}"
            for law in prog.laws]
