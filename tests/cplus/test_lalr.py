"""The parser's own LALR runtime (cplus/lalr.py) against lark, which builds its tables.

The runtime must return exactly lark's trees (shapes, names, token types and texts, the
positions the error messages and locations come from) and refuse exactly what lark refuses;
a plain ``cplus plan`` must then not import lark at all.
"""
from __future__ import annotations

import functools
import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from lark import Token as LarkToken
from lark import Tree as LarkTree

from cplus import lalr, parse_tables, parser
from cplus.errors import CPlusSyntaxError, Diagnostics, Source
from cplus.parser import parse_program

ROOT = Path(__file__).resolve().parents[2]


def _statements(corpus: Path) -> list[str]:
    out = []
    files = [p for p in sorted((corpus / "domains").rglob("*")) if p.is_file()]
    files += sorted((ROOT / "bench" / "data").glob("*.cp")) + sorted((ROOT / "domains").rglob("*.cp"))
    for path in files:
        try:
            text = path.read_text(encoding="utf-8")
            spans = parser.split_statements(Source(str(path), text), Diagnostics())
        except (UnicodeDecodeError, CPlusSyntaxError):
            continue
        out += [text[b:e] for b, e in spans if text[b:e].strip()]
    return out


def _lark_tree(chunk: str):
    try:
        return parse_tables._lark().parse(chunk)
    except Exception:           # lark's UnexpectedInput and its subclasses
        return None


def _ours(chunk: str):
    try:
        return parse_tables._parser().parse(chunk)
    except lalr.NoParse:
        return None


def _same(ours, theirs) -> None:
    """``ours`` is lark's tree ``theirs`` node for node, with the same positions."""
    todo = [(ours, theirs)]
    while todo:
        a, b = todo.pop()
        if isinstance(b, LarkTree):
            assert isinstance(a, lalr.Tree) and a.data == str(b.data)
            assert len(a.children) == len(b.children), (a, b)
            assert a.meta.empty == b.meta.empty
            if not b.meta.empty:
                assert (a.meta.start_pos, a.meta.end_pos) == (b.meta.start_pos, b.meta.end_pos), b.data
            todo += zip(a.children, b.children)
        else:
            assert isinstance(b, LarkToken) and isinstance(a, lalr.Token)
            assert (a.type, str(a), a.start_pos, a.end_pos) == (b.type, str(b), b.start_pos, b.end_pos)


def test_every_corpus_statement_parses_to_larks_tree(corpus: Path) -> None:
    chunks = _statements(corpus)
    assert len(chunks) > 1000
    parsed = 0
    for chunk in chunks:
        theirs = _lark_tree(chunk)
        ours = _ours(chunk)
        assert (ours is None) == (theirs is None), chunk
        if theirs is not None:
            _same(ours, theirs)
            parsed += 1
    assert parsed > 1000


_PIECES = [" ", "(", ")", ",", "-", "..", "::", ":-", "caused", "if", "after", "where", "x", "X",
           "1", "&", "++", "=", "\\/", "/\\", "abs", "mod", "->>", "<->>", ";", "*", "'", "%c\n",
           "/*a*/", "noconcurrency", "constants", "inertialFluent", "#1", "@<", "maxstep", "..5"]


@functools.lru_cache(maxsize=1)
def _corpus_statements() -> list[str]:
    return _statements(Path(os.environ.get("CPLUS_CORPUS", ROOT / "tests" / "corpus")))


@settings(max_examples=400)
@given(data=st.data())
def test_edited_statements_parse_or_fail_as_with_lark(data) -> None:
    chunk = data.draw(st.sampled_from(_corpus_statements()))
    for _ in range(data.draw(st.integers(1, 3))):
        i = data.draw(st.integers(0, len(chunk)))
        j = min(len(chunk), i + data.draw(st.integers(0, 4)))
        chunk = chunk[:i] + data.draw(st.sampled_from(_PIECES + [""])) + chunk[j:]
    theirs = _lark_tree(chunk)
    ours = _ours(chunk)
    assert (ours is None) == (theirs is None), chunk
    if theirs is not None:
        _same(ours, theirs)


def _fresh_tables(monkeypatch, cache: Path) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache))
    parse_tables._parser.cache_clear()


def test_tables_are_kept_and_rebuilt_when_stale_or_damaged(tmp_path: Path, monkeypatch) -> None:
    _fresh_tables(monkeypatch, tmp_path)
    try:
        assert parse_program("a causes b.").statements
        (kept,) = (tmp_path / "cplus").glob("tables-*.marshal")
        parse_tables._parser.cache_clear()
        kept.write_bytes(b"not marshal data")
        assert parse_program("a causes b.").statements      # damaged: rebuilt
        assert kept.read_bytes() != b"not marshal data"
        parse_tables._parser.cache_clear()
        import marshal
        fmt, _, tables = marshal.loads(kept.read_bytes())
        kept.write_bytes(marshal.dumps((fmt, "another grammar", {})))
        assert parse_program("a causes b.").statements      # another grammar's: rebuilt
        grammar = Path(parse_tables._GRAMMAR).read_text(encoding="utf-8")
        assert marshal.loads(kept.read_bytes())[1] == grammar
        parse_tables._parser.cache_clear()
        kept.write_bytes(marshal.dumps((fmt, grammar, {"states": {}})))
        assert parse_program("a causes b.").statements      # this grammar's, damaged: rebuilt
        assert marshal.loads(kept.read_bytes())[2] == tables
    finally:
        parse_tables._parser.cache_clear()


def test_an_unwritable_cache_still_parses(tmp_path: Path, monkeypatch) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    _fresh_tables(monkeypatch, blocker)         # the cache directory cannot be made
    try:
        assert len(parse_program("a causes b.  c causes d.").statements) == 2
        with pytest.raises(CPlusSyntaxError, match="unexpected"):
            parse_program("a causes causes b.")
    finally:
        parse_tables._parser.cache_clear()


def test_a_plan_does_not_import_lark(tmp_path: Path, corpus: Path) -> None:
    """lark is needed to build the tables once and to explain a syntax error, nothing else."""
    hanoi = next((corpus / "domains").rglob("hanoi-8-4-benchmark.cp"))
    code = ("import sys; from cplus.cli import main; code = main(['plan', sys.argv[1], '--query', '0']); "
            "print('lark' in sys.modules); sys.exit(code)")
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path)}
    runs = [subprocess.run([sys.executable, "-c", code, str(hanoi)], capture_output=True, text=True, env=env)
            for _ in range(2)]
    assert [r.returncode for r in runs] == [0, 0], runs[0].stderr
    assert [r.stdout.split()[-1] for r in runs] == ["True", "False"]   # built once, then read
    bad = tmp_path / "bad.cp"
    bad.write_text(":- constants a :: inertialFluent.\na causes causes a.\n")
    run = subprocess.run([sys.executable, "-m", "cplus", "plan", str(bad)], capture_output=True, text=True, env=env)
    assert run.returncode != 0 and "bad.cp:2:" in run.stderr and "Traceback" not in run.stderr


def test_no_home_directory_still_parses(monkeypatch) -> None:
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setattr(parse_tables.os.path, "expanduser", lambda path: path)   # "~" stays "~": no home
    parse_tables._parser.cache_clear()
    parse_tables._lark.cache_clear()
    try:
        assert parse_tables._cache_dir() is None
        assert len(parse_program("a causes b.").statements) == 1
        with pytest.raises(CPlusSyntaxError, match="unexpected"):
            parse_program("a causes causes b.")
    finally:
        parse_tables._parser.cache_clear()
        parse_tables._lark.cache_clear()
