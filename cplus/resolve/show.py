"""``:- show`` and ``:- hide``: which atoms a plan prints.

Patterns are not formulas: an argument may be a variable that matches anything, and no atom
is built, so they are resolved on their own, down to a declaration and arguments that are
objects or variables.  A show statement may also hold CCALC's specifications ``positive``,
``negative``, ``all``, ``ab`` and ``none`` (their meaning is :class:`cplus.output.Display`'s).
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import ResolveError
from cplus.program import SHOW_KEYWORDS, Pattern
from cplus.resolve.core import _Scope, _show
from cplus.resolve.terms import _Terms


def resolve_show(program, text: str, diagnostics) -> list:
    """The specifications of ``:- show TEXT.`` resolved against a resolved program, with its
    signature and the macros and variables in force at the end of its file: the shell's
    ``show SPEC.`` (CCALC's ``show/1``, which replaces the specifications before it).  Errors
    are :class:`~cplus.errors.CPlusError` located in ``":- show " + text``; warnings go to
    ``diagnostics``."""
    from cplus.parser import parse_program
    from cplus.program import Program
    from cplus.resolve import BUILTIN_EXTERNALS, _Resolver

    parsed = parse_program(f":- show {text}.", "<show>", diagnostics)
    (stmt,) = parsed.statements
    if not isinstance(stmt, ast.ShowHide):     # pragma: no cover - the text is one show statement
        raise ResolveError("expected show specifications", stmt.loc)
    r = _Resolver(lambda path, loc: parsed, BUILTIN_EXTERNALS, diagnostics)
    r.sig = program.signature
    r.program = Program(program.signature, diagnostics=diagnostics)
    r.macros, r.variables = program.scope or ({}, {})
    r._st_ShowHide(stmt)
    r._check_patterns()
    return r.program.show


class _Show(_Terms):
    def _st_ShowHide(self, stmt: ast.ShowHide) -> None:
        if stmt.hide:
            if stmt.all_:
                self.program.hide_all = True
            self.program.hide.extend(self._pattern(p) for p in stmt.patterns)
            return
        specs: list[Pattern | str] = ["all"] if stmt.all_ else []
        for p in stmt.patterns:
            keyword = self._keyword(p)
            specs.append(keyword if keyword is not None else self._pattern(p))
        self.program.show.extend(specs)
        self.program.show_given = True

    def _keyword(self, e: ast.Expr) -> str | None:
        """``positive``, ``negative``, ``ab`` or ``none`` as a show specification.  As in CCALC,
        the word is the keyword even when a constant has that name (warned: write the
        constant with its arguments or a value, ``positive=V``, to mean it)."""
        if not (isinstance(e, ast.Name) and not e.args and e.name in SHOW_KEYWORDS):
            return None
        if self.sig.constants_named(e.name):
            self.diag.warn(f"show specification '{e.name}' is ambiguous: it is a keyword of ':- show', so it does not "
                           f"name the constant '{e.name}' (write '{e.name}=V' or give its arguments for the "
                           "constant)", e.loc)
        return e.name

    def _pattern(self, e: ast.Expr) -> Pattern:
        e = self._expand(e)
        if isinstance(e, ast.Stamp):       # `t: c(args)`: CCALC's specification of one step
            step = self._static_int(self._expand(e.time))
            if step < 0:
                raise ResolveError(f"a show/hide pattern's step is 0 or more, not {step}", e.time.loc)
            p = self._pattern(e.body)
            p.step = step
            self.patterns_to_check.append((p, e.loc))
            return p
        loc = e.loc
        negated = False
        if isinstance(e, ast.Unary) and e.op == "not":
            negated, e = True, e.arg
        value = None
        if isinstance(e, ast.Binary) and e.op == "=":
            value = self._pattern_arg(e.right)
            e = e.left
        if not isinstance(e, ast.Name):
            raise ResolveError("a show/hide pattern is an atom 'c(args)' or 'c(args)=v'", e.loc)
        decl = self.sig.lookup(e.name, len(e.args))
        if decl is None:
            if not e.args and self.sig.constants_named(e.name):   # `show loc`: every instance of loc
                return Pattern(None, (), value, negated, e.name)
            raise ResolveError(f"unknown constant '{e.name}/{len(e.args)}' in show/hide", e.loc)
        p = Pattern(decl, tuple(self._pattern_arg(a) for a in e.args), value, negated)
        self.patterns_to_check.append((p, loc))
        return p

    def _check_patterns(self) -> None:
        """Warn at a show/hide pattern that can match no atom (once the sorts are complete):
        a value outside its constant's domain (``show n=7`` for ``n :: 0..3``), ``-c`` for a
        constant that is not Boolean, a step on a rigid constant (CCALC ignores such a
        specification with "Invalid show spec ... ignored", ccalc.pl ``process_show_internal``)."""
        seen: set[int] = set()
        for p, loc in self.patterns_to_check:
            if id(p) in seen or p.decl is None:
                continue
            seen.add(id(p))
            d = p.decl
            values = self.sig.objects_of(d.domain)
            if d.kind == "attribute" or (d.kind == "abAction" and values != ("true", "false")):
                values = values + ("none",)
            why = None
            if p.value is not None and not isinstance(p.value, ir.Var) and p.value not in values:
                shown = ", ".join(map(_show, values[:8])) + (", ..." if len(values) > 8 else "")
                why = f"'{_show(p.value)}' is not a value of '{d.name}' (its values: {shown})"
            elif p.negated and values != ("true", "false"):
                why = f"'-{d.name}' names a Boolean atom false, and '{d.name}' is not Boolean (write '{d.name}=V')"
            elif p.step is not None and d.kind == "rigid":
                why = f"'{d.name}' is rigid: it has no value at a step"
            if why is not None:
                self.diag.warn(f"this show/hide pattern matches nothing: {why}", loc)

    def _pattern_arg(self, a: ast.Expr):
        t = self._term(a, _Scope())
        if isinstance(t, (ir.Lit, ir.Var)):
            return t if isinstance(t, ir.Var) else t.value
        raise ResolveError("show/hide arguments are objects or variables", a.loc)
