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
        return {"not": "not", "-": "neg", "abs": "abs"}[e.op] + f"({shape(e.arg)})"
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
    # the examples of cplus-language.md A.4
    ("-door(d1)=open & bell ++ alarm", "((not((door(d1) = open)) & bell) ++ alarm)"),
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
        from cplus.ground.theory import ground_program
        ground_program(prog)
    return info.value


BASE = ":- sorts room. :- objects k, h :: room. :- variables R :: room.\n" \
       ":- constants lit(room) :: inertialFluent; lvl :: inertialFluent(0..3); flip(room) :: exogenousAction.\n"


@pytest.mark.parametrize("text, line, col, fragment", [
    (BASE + "flip(R) causes lit(R)\nflip(R) causes lvl=1.", 4, 1, "unexpected 'flip'"),  # missing '.'
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


def test_a_last_statement_without_period_is_reported_and_ignored(tmp_path):
    """CCALC's Prolog reader skips a clause it cannot end; so do we, with a warning."""
    path = tmp_path / "t.cp"
    path.write_text(":- constants p :: inertialFluent.\ncaused p")
    d = Diagnostics()
    load_program(str(path), diagnostics=d)
    assert [str(x.loc) for x in d.items] == [f"{path}:2:1"]
    assert "not ended by '.'" in d.items[0].render()


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


@settings(max_examples=400, deadline=None)
@given(st.lists(st.sampled_from(PIECES), max_size=30), st.text(max_size=20))
def test_nothing_but_project_errors_escape(pieces, noise):
    """Random token soup and random text: the front end answers or raises CPlusError."""
    for text in (" ".join(pieces), "".join(pieces) + noise, noise):
        try:
            load_text(text, "fuzz.cp")
        except CPlusError as err:
            assert err.render()
