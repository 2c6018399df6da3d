"""The parser and resolver: operator precedence, statement splitting, and every class of
bad input reported as ``file:line:col: error: message`` with the line and a caret."""
from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cplus import ast
from cplus.errors import CPlusError, CPlusSyntaxError, Diagnostics
from cplus.load import load_program, load_text
from cplus.parser import parse_program


def expr(text: str) -> ast.Expr:
    stmt = parse_program(text + ".", "t.cp").statements[0]
    assert isinstance(stmt, ast.Law)
    return stmt.head


def shape(e) -> str:
    """A compact, fully parenthesised rendering of an expression tree."""
    if isinstance(e, ast.Num):
        return str(e.value)
    if isinstance(e, ast.Name):
        return e.name + (f"({','.join(shape(a) for a in e.args)})" if e.args else "")
    if isinstance(e, ast.Unary):
        return {"not": "not", "-": "neg", "cneg": "neg", "abs": "abs"}[e.op] + f"({shape(e.arg)})"
    if isinstance(e, ast.Binary):
        return f"({shape(e.left)} {e.op} {shape(e.right)})"
    if isinstance(e, ast.Stamp):
        return f"({shape(e.time)}: {shape(e.body)})"
    if isinstance(e, ast.Quant):
        vs = " ".join(("E" if v.exists else "A") + v.name for v in e.vars)
        return f"[{vs} | {shape(e.body)}]"
    if isinstance(e, ast.MaxStep):
        return "maxstep"
    raise TypeError(e)


@pytest.mark.parametrize("text, expected", [
    # the examples of operator precedence (docs/language.md, section 4)
    # CCALC (Prolog): prefix minus binds tighter than `=`, so `-door(d1)=open` is `(-door(d1))=open`
    ("-door(d1)=open & bell ++ alarm", "(((neg(door(d1)) = open) & bell) ++ alarm)"),
    ("-(door(d1)=open) & bell", "(not((door(d1) = open)) & bell)"),
    ("-c+1=v", "((neg(c) + 1) = v)"),
    ("p & q ->> r ++ s <->> t", "(((p & q) ->> (r ++ s)) <->> t)"),
    ("level(T)+1 >= cap(T)*2", "((level(T) + 1) >= (cap(T) * 2))"),
    ("A+B-C*D mod 2 = 0", "(((A + B) - ((C * D) mod 2)) = 0)"),
    ("pos(x) = -1", "(pos(x) = neg(1))"),
    ("X = Y - -1", "(X = (Y - neg(1)))"),
    ("a -> b", None),
    ("p, q ->> r", "(p , (q ->> r))"),
    ("p ->> q ->> r", "(p ->> (q ->> r))"),
    ("[\\/X \\/Y | p(X) & q(Y)]", "[EX EY | (p(X) & q(Y))]"),
    ("-[\\/X | p(X)]", "not([EX | p(X)])"),
    ("abs(X-Y) \\= 2", "(abs((X - Y)) \\= 2)"),
])
def test_precedence(text, expected):
    if expected is None:
        with pytest.raises(CPlusSyntaxError):
            expr(text)
    else:
        assert shape(expr(text)) == expected


def test_time_stamps_cover_the_rest_of_an_item():
    q = parse_program(":- query maxstep :: 2; 0: -p, (q & r) <-> s, t=1; (0: pos(c)) \\= (1: pos(c)).",
                      "t.cp").statements[0]
    items = [i for i in q.items if isinstance(i, ast.QueryItem)]
    assert shape(items[0].formula) == "(0: ((not(p) , ((q & r) <->> s)) , (t = 1)))"
    assert shape(items[1].formula) == "((0: pos(c)) \\= (1: pos(c)))"


def test_a_stamp_cannot_be_an_operand():
    with pytest.raises(CPlusSyntaxError):
        parse_program(":- query 0: at(X) & 1: at(X).", "t.cp")


def test_statement_splitting():
    d = Diagnostics()
    prog = parse_program("""% comment with a . in it
:- objects 1..3 :: n.   /* block . comment */
:- begin_asp.
#hide h(x). p :- q.
:- end_asp.
p.%
q.NOOP
""", "t.cp", d)
    assert len(prog.statements) == 2
    msgs = [x.message for x in d.items]
    assert any("Cplus2ASP" in m for m in msgs)
    assert any("not ended by '.'" in m for m in msgs)
    assert [x.loc.line for x in d.items] == [3, 7]


# --------------------------------------------------------------------------- bad input


def located(tmp_path, text: str, name: str = "bad.cp", extra: dict[str, str] | None = None) -> CPlusError:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    for n, t in (extra or {}).items():
        (tmp_path / n).write_text(t, encoding="utf-8")
    with pytest.raises(CPlusError) as info:
        prog = load_program(str(path))
        for q in (*prog.queries, *prog.nmqueries):    # a bad query fails alone, when it is asked
            if q.error is not None:
                raise q.error
        from cplus.ground.theory import ground_program
        ground_program(prog)
    return info.value


BASE = ":- sorts room. :- objects k, h :: room. :- variables R :: room.\n" \
       ":- constants lit(room) :: inertialFluent; lvl :: inertialFluent(0..3); flip(room) :: exogenousAction.\n"


@pytest.mark.parametrize("text, line, col, fragment", [
    (BASE + "flip(R) causes lit(R)\nflip(R) causes lvl=1.", 3, 22, "missing '.' at the end of this statement"),
    ("/* never closed\n", 1, 1, "unterminated comment"),
    ("caused p if q.r.", 1, 14, "unexpected '.'"),
    ("caused p if q & .\n", 1, 17, "ends too early"),
    (BASE + "flip(R) causes lt(R).", 3, 16, "unknown constant or function 'lt/1'"),
    (BASE + "flip(R) causes lit(k,h).", 3, 16, "takes 1 argument"),
    (BASE + "flip(R) causes lit(kitchen).", 3, 20, "unknown name 'kitchen'"),
    (BASE + "flip(Q) causes lit(Q).", 3, 6, "unknown variable 'Q'"),
    (BASE + "flip(R) causes lit(3).", 3, 16, "not an object of sort 'room'"),
    (BASE + "flip(R) causes lvl=7.", 3, 16, "not in the domain"),
    (BASE + "caused lit(k) ++ lit(h).", 3, 1, "would not be definite"),
    (BASE + "caused -(lvl=1).", 3, 1, "not be definite"),
    (BASE + "caused lit(k) if lvl = k+1.", 3, 24, "arithmetic on the object 'k'"),
    (BASE + ":- variables N :: 0..3.\ncaused lit(k) if lvl=N where N // 0 = 1.", 4, 30, "division by zero"),
    (BASE + "caused lit(R) if flip(R).", 3, 1, "may not mention actions"),
    (":- sorts n. :- macros m(#1) -> m(#1) + 1.\n:- objects m(1) :: n.", 1, 32, "recursive macro"),
    (":- include 'nowhere.cp'.", 1, 12, "cannot find included file"),
    (":- query maxstep :: 5..2.", 1, 10, "malformed maxstep"),
    (":- sorts a. :- sorts a >> b; b >> a.", 1, 35, "b >> a' would make the sorts a cycle"),
    (":- constants p :: inertialFluent; p :: inertialFluent.", 1, 35, "declared twice"),
    (":- foo bar.", 1, 4, "unknown directive"),
    (":- constants n :: additiveFluent(0..3).", 1, 14, "maxAdditive"),
])
def test_bad_input_is_located(tmp_path, text, line, col, fragment):
    err = located(tmp_path, text)
    rendered = err.render()
    assert rendered.startswith(f"{tmp_path / 'bad.cp'}:{line}:{col}: error: "), rendered
    assert fragment in rendered
    assert "^" in rendered.splitlines()[2]


def test_text_at_the_end_that_is_no_statement_is_reported_and_ignored(tmp_path):
    """CCALC's Prolog reader skips a clause it cannot end; so do we, with a warning (a file of
    the conformance corpus ends so: ``throwOff(ANML,H).NOOP``)."""
    path = tmp_path / "t.cp"
    path.write_text(":- constants p :: inertialFluent.\ncaused p.NOOP")
    d = Diagnostics()
    load_program(str(path), diagnostics=d)
    assert [str(x.loc) for x in d.items] == [f"{path}:2:1"]
    assert "not ended by '.'" in d.items[0].render()


@pytest.mark.parametrize("last, col", [
    ("caused p", 9),
    (":- query label :: on; maxstep :: 0..2; 0: -p; maxstep: p", 57),
    ("caused p   % the period is missing.\n", 9),
])
def test_a_last_statement_without_its_period_is_an_error_at_its_end(tmp_path, last, col):
    """A whole statement but for its '.' is a forgotten '.', not text to skip: a file whose
    query lacks it would otherwise be told it has no queries."""
    err = located(tmp_path, ":- constants p :: inertialFluent.\n" + last)
    assert isinstance(err, CPlusSyntaxError)
    assert err.render().startswith(f"{tmp_path / 'bad.cp'}:2:{col}: error: missing '.' at the end of the file's "
                                   "last statement\n"), err.render()


@pytest.mark.parametrize("text, line, col", [
    ("flip causes lit\nnonexecutable flip if lit.", 1, 16),        # the example
    ("flip causes lit  % a comment.\n\n% another\ncaused lit.", 1, 16),
    ("flip causes lit\n:- query label :: on; maxstep :: 1; maxstep: lit.", 1, 16),
    (":- constants lit :: inertialFluent\n:- variables X :: 0..1.", 1, 35),
    ("caused lit if lit\n  after flip\nflip causes lit.", 2, 13),   # a law over two lines
])
def test_a_missing_period_is_reported_at_the_end_of_the_statement_that_lacks_it(text, line, col):
    with pytest.raises(CPlusSyntaxError) as info:
        parse_program(text, "t.cp")
    assert info.value.message == "missing '.' at the end of this statement (the next line starts another one)"
    assert (info.value.loc.line, info.value.loc.col) == (line, col)


STATEMENTS = [
    ":- sorts room", ":- objects kitchen, hall :: room", ":- variables R :: room",
    ":- constants at :: inertialFluent(room); go(room) :: exogenousAction",
    "go(R) causes at=R", "nonexecutable go(R) if at=R", "suck causes -dirty(R) if at=R",
    "go(R) increments cost by 2", "caused lit if lit after flip", "default -lit", "exogenous flip",
    "inertial lit", "constraint -(lit & dark)", "always lit", "lit", "flip may cause lit if dark",
    ":- query label :: tidy; maxstep :: 0..10; 0: at=hall; maxstep: -dirty(kitchen)",
    ":- show at; dirty(R)", ":- include 'base.cp'",
]
"""Well-formed statements, one line each, none of which continues the one before it."""


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(STATEMENTS), min_size=2, max_size=5), st.data())
def test_one_missing_period_among_statements_is_found_where_it_is_missing(statements, data):
    """Whichever statement lacks its '.', the error is at that statement's end."""
    missing = data.draw(st.integers(0, len(statements) - 2))
    text = "".join(s + ("\n" if k == missing else ".\n") for k, s in enumerate(statements))
    with pytest.raises(CPlusSyntaxError) as info:
        parse_program(text, "t.cp")
    assert "missing '.'" in info.value.message
    assert (info.value.loc.line, info.value.loc.col) == (missing + 1, len(statements[missing]) + 1)


@pytest.mark.parametrize("text, fragment", [
    ("clean cause lit.", "unexpected 'cause' (did you mean 'causes'?)"),
    ("flip causes lit unles dark.", "unexpected 'unles' (did you mean 'unless'?)"),
    ("go(R) increment cost by 2.", "unexpected 'increment' (did you mean 'increments'?)"),
    ("nonexecutible flip if lit.", "unexpected 'flip' ('nonexecutible' is not a keyword: did you mean "
                                   "'nonexecutable'?)"),
    (":- constant lit :: inertialFluent.", "unknown directive ':- constant' (did you mean ':- constants'? known:"),
])
def test_a_misspelled_keyword_gets_a_suggestion(text, fragment):
    with pytest.raises(CPlusSyntaxError) as info:
        parse_program(text, "t.cp")
    assert fragment in info.value.message


@pytest.mark.parametrize("text", ["caused p if q r.", "flip causes lit if dark wet."])
def test_a_name_far_from_every_keyword_gets_no_suggestion(text):
    with pytest.raises(CPlusSyntaxError) as info:
        parse_program(text, "t.cp")
    assert "did you mean" not in info.value.message


def test_include_cycle_is_an_error(tmp_path):
    err = located(tmp_path, ":- include 'b.cp'.", "a.cp", {"b.cp": ":- include 'a.cp'."})
    assert "include cycle: a.cp -> b.cp -> a.cp" in err.render()
    assert err.render().startswith(f"{tmp_path / 'b.cp'}:1:12: error:")


def test_include_is_relative_to_the_including_file(tmp_path, monkeypatch):
    sub = tmp_path / "lib"
    sub.mkdir()
    (sub / "base.cp").write_text(":- constants p :: inertialFluent.")
    (sub / "main.cp").write_text(":- include 'base.cp'. :- include base. :- query maxstep :: 0.")
    monkeypatch.chdir(tmp_path)
    prog = load_program(str(sub / "main.cp"))
    assert prog.signature.lookup("p", 0) is not None


@pytest.mark.parametrize("data, fragment", [
    (b"\x00\x01\x02binary", "binary file"),
    (b":- constants p :: inertialFluent.\n% caf\xe9\n", "not UTF-8"),
])
def test_binary_and_non_utf8_input(tmp_path, data, fragment):
    path = tmp_path / "bad.cp"
    path.write_bytes(data)
    with pytest.raises(CPlusError) as info:
        load_program(str(path))
    assert fragment in info.value.render()
    assert info.value.render().startswith(str(path) + ":")


def test_missing_file():
    with pytest.raises(CPlusError, match="no such file"):
        load_program("/nonexistent/domain.cp")


# --------------------------------------------------------------------------- fuzzing

PIECES = [":-", "sorts", "objects", "constants", "variables", "query", "macros", "maxstep", "label",
          "::", ":", ";", ",", ".", "..", "(", ")", "[", "]", "|", "\\/", "/\\", "&", "++", "->>",
          "<->>", "-", "+", "*", "//", "mod", "=", "\\=", "==", "<", "=<", "@<", "caused", "if",
          "after", "causes", "where", "unless", "nonexecutable", "default", "exogenous", "inertial",
          "constraint", "always", "increments", "by", "p", "q(X)", "X", "Y", "a", "0", "1", "12",
          "inertialFluent", "exogenousAction", "attribute", "of", "#1", "->", "'f.cp'", "%", "/*", "*/",
          "\n", " ", "true", "false", "none", "abs", "noconcurrency", "include", "show", "hide", "all"]


@settings(max_examples=400)
@given(st.lists(st.sampled_from(PIECES), max_size=30), st.text(max_size=20))
def test_nothing_but_project_errors_escape(pieces, noise):
    """Random token soup and random text: the front end answers or raises CPlusError."""
    for text in (" ".join(pieces), "".join(pieces) + noise, noise):
        try:
            load_text(text, "fuzz.cp")
        except CPlusError as err:
            assert err.render()


# --------------------------------------------------------------------------- keywords


def test_the_grammar_and_the_parser_reserve_the_same_words():
    """IDENT in the grammar excludes exactly the words RESERVED documents."""
    import re
    from pathlib import Path

    from cplus.parser import RESERVED
    grammar = (Path(__file__).resolve().parents[2] / "cplus" / "grammar" / "cplus.lark").read_text()
    words = re.search(r"IDENT: /\(\?!\(\?:([a-z_|]+)\)", grammar).group(1).split("|")
    assert set(words) == RESERVED


@pytest.mark.parametrize("word", sorted(__import__("cplus.parser", fromlist=["RESERVED"]).RESERVED))
def test_a_keyword_is_not_a_name(tmp_path, word):
    err = located(tmp_path, f":- constants {word} :: inertialFluent.")
    assert err.render().startswith(f"{tmp_path / 'bad.cp'}:1:14: error: unexpected '{word}'")


def test_a_keyword_where_a_name_should_be_is_reported_at_the_keyword(tmp_path):
    err = located(tmp_path, ":- constants lit :: inertialFluent.\ncaused lit if if lit.")
    assert err.render().startswith(f"{tmp_path / 'bad.cp'}:2:15: error: unexpected 'if' ('if' is a keyword")


@pytest.mark.parametrize("name", ["never", "impossible", "inertialFluent", "rigid", "may", "cause", "min"])
def test_words_that_are_not_ccalc_keywords_stay_names(name):
    """Cplus2ASP's additions and constant kinds may still name things, as in CCALC files."""
    prog = load_text(f":- sorts s. :- objects {name} :: s. :- query label :: {name}; maxstep :: 0.")
    assert name in prog.signature.sorts["s"].objects and prog.queries[0].label == name


# --------------------------------------------------------------------------- Cplus2ASP spellings


def histories(text: str) -> int:
    from cplus import Domain
    return len(Domain.from_text(text).solve("0", solutions=0).histories)


NUMS = ":- sorts n. :- objects 0..3 :: n. :- variables X :: n. :- constants c :: inertialFluent(n).\n"


@pytest.mark.parametrize("cplus2asp, ccalc", [
    ("c <= 2", "c =< 2"), ("c => 2", "c >= 2"), ("c <> 2", "c \\= 2"),
    ("[\\/X | X @<= c & c @=> X]", "[\\/X | X @=< c & c @>= X]"),
])
def test_cplus2asp_comparisons_mean_ccalcs(cplus2asp, ccalc):
    """Read as CCALC's operator, and the same histories."""
    assert shape(expr(cplus2asp)) == shape(expr(ccalc))
    query = ":- query maxstep :: 0; 0: {}."
    assert histories(NUMS + query.format(cplus2asp)) == histories(NUMS + query.format(ccalc)) > 0


def test_tilde_is_the_false_atom_of_a_boolean_constant():
    base = ":- constants p, q :: inertialFluent.\n"
    assert histories(base + ":- query maxstep :: 0; 0: ~p & q.") == histories(base + ":- query maxstep :: 0; 0: -p & q.") == 1
    assert shape(expr("caused p if ~q")) == "p"
    assert shape(parse_program("caused p if ~q.", "t.cp").statements[0].if_) == "not(q)"


def test_tilde_on_a_formula_says_what_to_write(tmp_path):
    err = located(tmp_path, ":- constants p, q :: inertialFluent.\ncaused p if ~(p & q).")
    assert "'~c' is CCALC's '-c'; to negate a formula write '-(F)'" in err.message
    assert (err.loc.line, err.loc.col) == (2, 13)


def test_double_negation_in_a_body_is_the_formula():
    base = ":- constants p, q :: inertialFluent.\n"
    assert histories(base + ":- query maxstep :: 0; 0: --(p & q).") == histories(base + ":- query maxstep :: 0; 0: p & q.")


def test_double_negation_in_a_head_names_the_ccalc_form(tmp_path):
    err = located(tmp_path, ":- constants p :: inertialFluent; a :: exogenousAction.\ncaused --(p) after a.")
    assert "Cplus2ASP's choice" in err.message and "write 'default F'" in err.message
    assert (err.loc.line, err.loc.col) == (2, 1)


@pytest.mark.parametrize("text, hint", [
    ("caused p if X != 1.", "write '\\=' for 'not equal'"),
    ("caused p if q | r.", "write '++' for 'or'"),
])
def test_other_cplus2asp_spellings_say_what_to_write(tmp_path, text, hint):
    err = located(tmp_path, text)
    assert hint in err.message and (err.loc.line, err.loc.col) == (1, 15)


# --------------------------------------------------------------------------- ranges and macros


def objects(text: str, sort: str) -> list:
    return list(load_text(text).signature.sorts[sort].objects)


MACROS = ":- macros n -> 3; lo -> 1; span(#1) -> #1..#1+1; r -> 1..n; neg -> -n..n.\n:- sorts s.\n"


@pytest.mark.parametrize("decl, expected", [
    # objects: ranges with literal, macro and expression bounds
    (":- objects 1..n :: s.", [1, 2, 3]),
    (":- objects n-1..n+1 :: s.", [2, 3, 4]),
    (":- objects -n..-n+1 :: s.", [-3, -2]),
    (":- objects r :: s.", [1, 2, 3]),
    (":- objects span(5) :: s.", [5, 6]),
    (":- objects neg :: s.", [-3, -2, -1, 0, 1, 2, 3]),
    # constructor arguments: the same, plus sorts and several arguments
    (":- objects post(1..2) :: s.", [("post", 1), ("post", 2)]),
    (":- objects post(lo..n) :: s.", [("post", 1), ("post", 2), ("post", 3)]),
    (":- objects post(n-1..2*n-4) :: s.", [("post", 2)]),
    (":- objects post(r) :: s.", [("post", 1), ("post", 2), ("post", 3)]),
    (":- objects post(span(n)) :: s.", [("post", 3), ("post", 4)]),
    (":- objects cell(1..2, lo..lo) :: s.", [("cell", 1, 1), ("cell", 2, 1)]),
    (":- sorts t. :- objects a, b :: t. :- objects at(t, n..n) :: s.", [("at", "a", 3), ("at", "b", 3)]),
    (":- sorts t. :- objects a :: t. :- objects at(t*) :: s.", [("at", "a"), ("at", "none")]),
])
def test_ranges_take_macros_and_integer_expressions_in_objects(decl, expected):
    assert objects(MACROS + decl, "s") == expected


@pytest.mark.parametrize("decl, expected", [
    (":- constants c :: inertialFluent(n..5).", "3..5"),
    (":- constants c :: inertialFluent(n-1..n+1).", "2..4"),
    (":- constants c :: inertialFluent(-n..n).", "-3..3"),
    (":- constants c :: inertialFluent(abs(0-n)..n).", "3..3"),
    (":- constants c :: inertialFluent(r).", "1..3"),
    (":- constants c :: inertialFluent(span(2)).", "2..3"),
    (":- constants c :: 2*lo..n.", "2..3"),
    (":- constants c :: span(n).", "3..4"),
    (":- constants c :: r.", "1..3"),
    (":- constants c :: rigid(lo..n*2).", "1..6"),
    (":- constants c :: simpleFluent(s*).", "s*"),
    (":- constants c :: simpleFluent(s+none).", "s*"),
    (":- constants a :: exogenousAction; c :: attribute(lo..n) of a.", "1..3"),
])
def test_ranges_take_macros_and_integer_expressions_as_domains(decl, expected):
    prog = load_text(MACROS + decl)
    assert str(prog.signature.lookup("c", 0).domain) == expected


@pytest.mark.parametrize("decl, argsorts", [
    (":- constants c(n..n+1) :: inertialFluent.", ["3..4"]),
    (":- constants c(r, s*) :: inertialFluent.", ["1..3", "s*"]),
    (":- constants c(span(0)) :: inertialFluent.", ["0..1"]),
    (":- constants a(s) :: exogenousAction; c(s, lo..n) :: attribute(span(1)) of a(s+none).", None),
])
def test_ranges_take_macros_and_integer_expressions_as_argument_sorts(decl, argsorts):
    if argsorts is None:   # the parent's argument sorts must match: s vs s* is refused, located
        with pytest.raises(CPlusError, match="argument sorts of 'a'"):
            load_text(MACROS + decl)
        return
    prog = load_text(MACROS + decl)
    assert [str(s) for s in prog.signature.lookup("c", len(argsorts)).argsorts] == argsorts


@pytest.mark.parametrize("decl, sort", [
    (":- variables X :: n..n+2.", "3..5"),
    (":- variables X :: 2*lo..n.", "2..3"),
    (":- variables X :: r.", "1..3"),
    (":- variables X :: span(7).", "7..8"),
    (":- variables X :: s*.", "s*"),
])
def test_ranges_take_macros_and_integer_expressions_as_variable_sorts(decl, sort):
    from cplus.resolve import _Resolver
    r = _Resolver(lambda p, loc: None, None, Diagnostics())  # type: ignore[arg-type]
    r.run(parse_program(MACROS + decl, "t.cp"))
    assert str(r.variables["X"].sort) == sort


@pytest.mark.parametrize("query, label, lo, hi", [
    (":- query maxstep :: n.", "0", 3, 3),
    (":- query maxstep :: lo..n+1.", "0", 1, 4),
    (":- query maxstep :: n..infinity.", "0", 3, None),
    (":- query maxstep :: r.", "0", 1, 3),
    (":- query label :: n; maxstep :: 0.", "3", 0, 0),
    (":- query label :: n*2+1; maxstep :: 0.", "7", 0, 0),
    (":- query label :: go; maxstep :: 0.", "go", 0, 0),
])
def test_queries_take_macros_and_integer_expressions(query, label, lo, hi):
    q = load_text(MACROS + query).queries[0]
    assert (q.label, q.lo, q.hi) == (label, lo, hi)


def test_max_additive_takes_an_expression():
    assert load_text(MACROS + ":- maxAdditive :: n*2+1.").signature.max_additive == 7


@pytest.mark.parametrize("text, fragment", [
    ("caused p if 1..3.", "a range 'lo..hi' may only occur in declarations"),
    ("caused p if c(1..2).", "a range 'lo..hi' may only occur in declarations"),
    (":- query maxstep :: 0; 0: c(s*).", "the sort 's*' may only occur in declarations"),
])
def test_ranges_and_star_sorts_elsewhere_are_located_errors(tmp_path, text, fragment):
    err = located(tmp_path, ":- sorts s. :- constants p :: inertialFluent; c(s) :: inertialFluent.\n" + text)
    assert fragment in err.message and err.loc.line == 2


# --------------------------------------------------------------------------- declarations


def test_an_empty_range_of_objects_is_a_warning(tmp_path):
    d = Diagnostics()
    prog = load_text(":- sorts n. :- objects 5..2, 7 :: n.", "t.cp", diagnostics=d)
    assert prog.signature.sorts["n"].objects == [7]
    assert [(x.message, x.loc.col) for x in d.items] == [("the range 5..2 is empty: it declares no objects", 24)]


@pytest.mark.parametrize("decl", [":- constants c :: inertialFluent(5..2).", ":- variables X :: 5..2.",
                                  ":- constants c(5..2) :: inertialFluent."])
def test_an_empty_range_as_a_sort_is_an_error(tmp_path, decl):
    err = located(tmp_path, decl)
    assert "empty range 5..2: a sort must have at least one object" in err.message


def test_a_variable_redeclared_with_another_sort_is_an_error(tmp_path):
    err = located(tmp_path, ":- sorts s; t.\n:- variables X :: s.\n:- variables Y, X :: t.")
    assert err.render().startswith(f"{tmp_path / 'bad.cp'}:3:17: error: variable X is declared again with "
                                   f"another sort: 't' here, 's' at {tmp_path / 'bad.cp'}:2:14")


def test_a_variable_redeclared_with_the_same_sort_is_fine():
    """Files that include a common part often repeat its declarations: silently, and the
    variable keeps its sort."""
    prog = load_text(":- sorts s. :- objects a :: s. :- constants p(s) :: inertialFluent.\n"
                     ":- variables X :: s. :- variables X, Y :: s. :- variables X :: s.\n"
                     "caused p(X) if p(Y).")
    assert prog.diagnostics.items == []
    (law,) = prog.laws
    assert [(v.name, str(v.sort)) for v in (law.head.cst.args[0], law.body.cst.args[0])] == [("X", "s"), ("Y", "s")]


def test_sorts_nest_in_declaration_order():
    (stmt,) = parse_program(":- sorts a >> (b; c >> d) >> e; f.", "t.cp").statements
    assert [(d.name, d.parent) for d in stmt.decls] == [
        ("a", None), ("b", "a"), ("c", "a"), ("d", "c"), ("e", "a"), ("f", None)]


def test_a_byte_order_mark_is_not_text(tmp_path):
    path = tmp_path / "bom.cp"
    path.write_bytes(b"\xef\xbb\xbf:- constants p :: inertialFluent.\ncaused q.")
    with pytest.raises(CPlusError) as info:
        load_program(str(path))
    assert info.value.render().startswith(f"{path}:2:8: error: unknown name 'q'")
    assert load_text("\ufeff:- constants p :: inertialFluent.").signature.lookup("p", 0)


@pytest.mark.parametrize("law, states", [
    ("caused -true if q.", 2), ("caused -false.", 4), ("caused p & -false.", 2), ("caused p & -true if q.", 2),
    ("default -true.", 4),
])
def test_negated_truth_values_in_heads(law, states):
    """``-true`` in a head is ``false`` (a constraint), ``-false`` is ``true`` (nothing caused)."""
    text = f":- constants p, q :: inertialFluent.\n{law}\n:- query maxstep :: 0."
    assert histories(text) == states


def test_a_long_line_is_cut_around_the_caret_in_messages(tmp_path):
    err = located(tmp_path, ":- constants p :: inertialFluent.\ncaused p if " + " & ".join(["p"] * 2000) + " & zz.")
    _, line, caret = err.render().splitlines()
    assert len(line) < 120 and line.strip().startswith("...") and line.endswith("zz.")
    assert line[caret.index("^"):caret.index("^") + 2] == "zz"
