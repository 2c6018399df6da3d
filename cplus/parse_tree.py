"""The walk from a parse tree to :mod:`cplus.ast`, without recursion: :class:`_TreeWalk` keeps
its own stack, regroups long chains of one associative operator into balanced trees, and
shortens runs of prefix operators.

The base of the parser's builder (:class:`cplus.parser._Builder`); the rules it applies per
grammar rule are :mod:`cplus.parse_declarations`' and :mod:`cplus.parse_formulas`'.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from cplus import ast
from cplus.errors import Location, Source
from cplus.lalr import Token, Tree

if TYPE_CHECKING:
    pass


_CHAIN_MIN = 9
"""Chains of one associative operator longer than this are regrouped into a balanced tree."""

_CONNECTIVES = {"and_": "&", "or_": "++", "comma": ",", "andand": "&&", "oror": "||"}
_UNARY_RUNS = ("neg", "uminus", "abs_")

class _Combine:
    """A step of the walk: take the last ``count`` values and combine them."""

    __slots__ = ("count", "finish")

    def __init__(self, count: int, finish) -> None:
        self.count = count
        self.finish = finish


def _spine(node: Tree) -> tuple[list, list]:
    """The operands and operators of a left-nested chain of one operator (``+``/``-`` count
    as one), without recursion."""
    rule = str(node.data)
    group = None if rule != "arith" else ("+", "-") if str(node.children[1]) in ("+", "-") else ("*",)
    operands: list = []
    ops: list = []
    cur = node
    while isinstance(cur, Tree) and str(cur.data) == rule and (group is None or str(cur.children[1]) in group):
        operands.append(cur.children[-1])
        if group is not None:
            ops.append(cur.children[1])
        cur = cur.children[0]
    operands.append(cur)
    operands.reverse()
    ops.reverse()
    return operands, ops


def _balanced(rule: str, ops: list):
    """Combine a chain's operand values into a balanced tree of Binary nodes."""
    def finish(builder: _TreeWalk, values: list):
        if rule == "arith" and ops[0] != "*":
            values = [values[0]] + [ast.Unary(Location(builder.source, builder.base + op.start_pos, v.loc.end), "-", v)
                                    if str(op) == "-" else v for op, v in zip(ops, values[1:])]
        op = _CONNECTIVES.get(rule) or ("*" if str(ops[0]) == "*" else "+")

        def tree(lo: int, hi: int):
            if hi - lo == 1:
                return values[lo]
            mid = (lo + hi + 1) // 2
            left, right = tree(lo, mid), tree(mid, hi)
            return ast.Binary(builder._span(left, right), op, left, right)
        return tree(0, len(values))
    return finish


def _minus_leftmost(e, loc: Location):
    """``-`` applied to the leftmost operand of an arithmetic term (Prolog's prefix minus)."""
    if isinstance(e, ast.Binary) and e.op in ast.ARITH_OPS:
        return ast.Binary(e.loc, e.op, _minus_leftmost(e.left, loc), e.right)
    return ast.Unary(Location(loc.source, loc.start, e.loc.end), "cneg", e)


def _unary_run(rule: str, metas: list):
    """Apply the prefix operator of a shortened run (one or two of them) to its operand."""
    def finish(builder: _TreeWalk, values: list):
        value = values[0]
        for meta in reversed(metas):
            value = getattr(builder, rule)(meta, [value])
        return value
    return finish

class _TreeWalk:
    """Lark tree -> :mod:`cplus.ast` (one instance per statement: it knows the offset).

    The tree is walked with an explicit stack, never by recursion, so that a law with
    thousands of conjuncts or a long chain of minus signs cannot exhaust Python's stack.
    While walking, chains of one associative operator longer than ``_CHAIN_MIN`` are regrouped
    into a balanced tree (``a - b`` becoming ``a + -b`` inside sums: equal for integers and
    equally undefined otherwise), and runs of prefix operators are shortened to what they mean
    (``- - - p`` is ``-p``; an even run keeps two, so ``--p`` stays recognisable).  Every later
    pass over the syntax tree then recurses at most ``MAX_NESTING`` levels deep.
    """

    def __init__(self, source: Source, base: int) -> None:
        self.source = source
        self.base = base

    # -------------------------------------------------------------- the walk
    def build(self, tree: Tree | Token):
        values: list = []
        todo: list = [tree]
        while todo:
            item = todo.pop()
            if isinstance(item, _Combine):
                n = item.count
                args = values[len(values) - n:] if n else []
                del values[len(values) - n:]
                values.append(item.finish(self, args))
            elif isinstance(item, Tree):
                todo.extend(self._plan(item))
            else:
                values.append(item)
        (result,) = values
        return result

    def _plan(self, node: Tree) -> list:
        """What to do for ``node``: a combine step, then its operands (reversed: a stack)."""
        rule = str(node.data)
        children = node.children
        if rule in _UNARY_RUNS:
            run = [node]
            while isinstance(run[-1].children[-1], Tree) and str(run[-1].children[-1].data) == rule:
                run.append(run[-1].children[-1])
            if len(run) > 1:
                keep = [run[0]] if (len(run) % 2 or rule == "abs_") else [run[0], run[-1]]
                operand = run[-1].children[-1]
                return [_Combine(1, _unary_run(rule, [n.meta for n in keep])), operand]
        if rule in _CONNECTIVES or (rule == "arith" and str(children[1]) in ("+", "-", "*")):
            operands, ops = _spine(node)
            if len(operands) > _CHAIN_MIN:
                return [_Combine(len(operands), _balanced(rule, ops)), *reversed(operands)]
        method = getattr(self, rule)
        return [_Combine(len(children), lambda b, args, m=method, meta=node.meta: m(meta, args)),
                *reversed(children)]

    def _loc(self, meta) -> Location:
        if getattr(meta, "empty", True):
            return Location(self.source, self.base, self.base)
        return Location(self.source, self.base + meta.start_pos, self.base + meta.end_pos)

    def _tloc(self, tok: Token) -> Location:
        return Location(self.source, self.base + tok.start_pos, self.base + tok.end_pos)

    def _span(self, first, last) -> Location:
        return Location(self.source, first.loc.start, last.loc.end)

