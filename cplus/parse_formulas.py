"""The builder's rules for C+ laws and formulas: the causal laws and their abbreviations, the
connectives, comparisons, arithmetic, names, numbers and quantifiers.

One of the two halves of :class:`cplus.parser._Builder` (one method per grammar rule), kept
apart from the declarations (:mod:`cplus.parse_declarations`).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from cplus import ast
from cplus.errors import CPlusSyntaxError, Location
from cplus.limits import MAX_INT
from cplus.parse_text import _skip_blank
from cplus.parse_tree import _minus_leftmost, _TreeWalk

if TYPE_CHECKING:
    pass


def _int_value(text: str) -> int | None:
    """The value of an integer literal, or None when it exceeds MAX_INT (checked on the digits
    first: Python refuses to convert strings of more than a few thousand digits)."""
    digits = text.lstrip("0") or "0"
    if len(digits) > len(str(MAX_INT)):
        return None
    value = int(digits)
    return value if value <= MAX_INT else None


_CPLUS2ASP_CMP = {"<=": "=<", "=>": ">=", "<>": "\\=", "@<=": "@=<", "@=>": "@>="}
"""Cplus2ASP's spellings of CCALC's comparisons (same meaning, so accepted)."""


class _FormulaRules(_TreeWalk):
    """Laws and formulas: one method per grammar rule, given the rule's meta and its
    children's values."""

    # -------------------------------------------------------------- laws
    def tail(self, meta, ch):
        parts: dict[str, ast.Expr] = {}
        for kind, expr in ch:
            parts[kind] = expr
        return parts

    def if_part(self, meta, ch):
        return ("if_", ch[0])

    def after_part(self, meta, ch):
        return ("after", ch[0])

    def unless_part(self, meta, ch):
        return ("unless", ch[0])

    def where_part(self, meta, ch):
        return ("where", ch[0])

    def _law(self, meta, kind, head, tail, **extra):
        return ast.Law(self._loc(meta), kind, head, if_=tail.get("if_"), after=tail.get("after"),
                       unless=tail.get("unless"), where=tail.get("where"), **extra)

    def caused(self, meta, ch):
        return self._law(meta, "caused", ch[0], ch[1])

    def possibly_caused(self, meta, ch):
        return self._law(meta, "default", ch[0], ch[1])

    def causes(self, meta, ch):
        return self._law(meta, "causes", ch[1], ch[2], action=ch[0])

    def may_cause(self, meta, ch):
        return self._law(meta, "may_cause", ch[1], ch[2], action=ch[0])

    def increments(self, meta, ch):
        action, incdec, target, amount, tail = ch
        return self._law(meta, "increments", target, tail, action=action, amount=amount,
                         decrement=str(incdec) == "decrements")

    def nonexecutable(self, meta, ch):
        return self._law(meta, "nonexecutable", ch[0], ch[1])

    def default(self, meta, ch):
        return self._law(meta, "default", ch[0], ch[1])

    def exogenous(self, meta, ch):
        return self._law(meta, "exogenous", ch[0], ch[1])

    def inertial(self, meta, ch):
        return self._law(meta, "inertial", ch[0], ch[1])

    def constraint(self, meta, ch):
        return self._law(meta, "constraint", ch[0], ch[1])

    def always(self, meta, ch):
        return self._law(meta, "always", ch[0], ch[1])

    def rigid(self, meta, ch):
        return self._law(meta, "rigid", ch[0], ch[1])

    def never(self, meta, ch):
        return self._law(meta, "never", ch[1], ch[2])

    def fact(self, meta, ch):
        return self._law(meta, "fact", ch[0], ch[1])

    # -------------------------------------------------------------- expressions
    def stamp(self, meta, ch):
        return ast.Stamp(self._loc(meta), ch[0], ch[1])

    def _bin(self, meta, op, ch):
        return ast.Binary(self._loc(meta), op, ch[0], ch[-1])

    def comma(self, meta, ch):
        return self._bin(meta, ",", ch)

    def oror(self, meta, ch):
        return self._bin(meta, "||", ch)

    def andand(self, meta, ch):
        return self._bin(meta, "&&", ch)

    def equiv(self, meta, ch):
        return self._bin(meta, "<->>", ch)

    def implies(self, meta, ch):
        return self._bin(meta, "->>", ch)

    def or_(self, meta, ch):
        return self._bin(meta, "++", ch)

    def and_(self, meta, ch):
        return self._bin(meta, "&", ch)

    def neg(self, meta, ch):
        arg = ch[0]
        if isinstance(arg, ast.Binary) and arg.op in ast.COMPARE_OPS and not self._parenthesized(meta, arg):
            # `-c=v`: Prolog's prefix minus binds tighter than `=`, so CCALC reads `(-c)=v`
            # (the minus on the leftmost operand: `-c+1=v` is `((-c)+1)=v`)
            return ast.Binary(arg.loc, arg.op, _minus_leftmost(arg.left, self._loc(meta)), arg.right)
        if isinstance(arg, ast.Range):   # `-n..n` in a macro body: the minus belongs to the bound
            start = self.base + meta.start_pos
            lo = ast.Unary(Location(self.source, start, arg.lo.loc.end), "-", arg.lo)
            return ast.Range(self._loc(meta), lo, arg.hi)
        return ast.Unary(self._loc(meta), "not", arg)

    def _parenthesized(self, meta, arg) -> bool:
        """Whether the operand of the ``-`` at ``meta`` opens with a parenthesis that encloses it
        whole (``-(c=v)``, negation) rather than only its left side (``-(c)=v``)."""
        text = self.source.text
        at = _skip_blank(text, self.base + meta.start_pos + 1)
        return at < len(text) and text[at] == "(" and arg.loc.start > at

    def tilde(self, meta, ch):
        """Cplus2ASP's ``~c`` is the atom ``c=false`` of a Boolean constant: CCALC's ``-c``."""
        arg = ch[0]
        if not isinstance(arg, ast.Name):
            raise CPlusSyntaxError("'~' (a Cplus2ASP spelling) applies to a Boolean constant: "
                                   "'~c' is CCALC's '-c'; to negate a formula write '-(F)'", self._loc(meta))
        return ast.Unary(self._loc(meta), "not", arg)

    def compare(self, meta, ch):
        op = str(ch[1])
        return ast.Binary(self._loc(meta), _CPLUS2ASP_CMP.get(op, op), ch[0], ch[2])

    def arith(self, meta, ch):
        return ast.Binary(self._loc(meta), str(ch[1]), ch[0], ch[2])

    def abs_(self, meta, ch):
        return ast.Unary(self._loc(meta), "abs", ch[-1])

    def uminus(self, meta, ch):
        return ast.Unary(self._loc(meta), "-", ch[0])

    def number(self, meta, ch):
        value = _int_value(str(ch[0]))
        if value is None:
            text = str(ch[0])
            shown = text if len(text) <= 24 else f"{text[:12]}...{text[-6:]} ({len(text)} digits)"
            raise CPlusSyntaxError(f"the integer {shown} is too large: integers are limited to "
                                   f"{MAX_INT} (2^63-1)", self._tloc(ch[0]))
        return ast.Num(self._tloc(ch[0]), value)

    def name(self, meta, ch):
        return ast.Name(self._tloc(ch[0]), str(ch[0]))

    def app(self, meta, ch):
        return ast.Name(self._loc(meta), str(ch[0]), tuple(ch[1:]))

    def param(self, meta, ch):
        return ast.Param(self._tloc(ch[0]), int(str(ch[0])[1:]))

    def maxstep(self, meta, ch):
        return ast.MaxStep(self._loc(meta))

    def quant(self, meta, ch):
        *qvars, body = ch
        return ast.Quant(self._loc(meta), tuple(qvars), body)

    def quant_var(self, meta, ch):
        return ast.QuantVar(self._tloc(ch[1]), str(ch[0]) == "\\/", str(ch[1]))

    def quant_anon(self, meta, ch):
        """``[\\/var(s, k) | F]``: CCALC's anonymous variable of sort ``s`` as a quantified one."""
        quant, fn, sort, key = ch
        if str(fn) != "var":
            raise CPlusSyntaxError(f"a quantifier binds a variable or 'var(sort, k)', not '{fn}(...)'",
                                   self._tloc(fn))
        return ast.QuantVar(Location(self.source, self.base + fn.start_pos, self.base + meta.end_pos),
                            str(quant) == "\\/", f"var({sort},{key})")
