"""The checks that wait for the end of the domain.

An object may be declared after the law that names it, and the sizes of the sorts grow with
every ``:- objects``, so these checks cannot run inside the statement resolvers: they run
once, over the finished signature and program.
"""
from __future__ import annotations

from cplus import ir
from cplus.errors import SortError
from cplus.limits import MAX_GROUND_CONSTANTS, count
from cplus.program import Program
from cplus.resolve.core import _Core, _show
from cplus.signature import KindSort, Signature, SortExpr, StepSort


class _EndChecks(_Core):
    def _check_ground_size(self) -> None:
        """Refuse, before enumerating them, more ground constants than MAX_GROUND_CONSTANTS."""
        total = 0
        for d in self.sig.constants.values():
            sizes = [len(self.sig.objects_of(s)) for s in d.argsorts]
            n = 1
            for k in sizes:
                n *= k
            total += n
            if total > MAX_GROUND_CONSTANTS:
                product = " x ".join(f"{k:,}" for k in sizes)
                raise SortError(f"'{d.name}/{d.arity}' has {count(n)} ground instances ({product})"
                                + ("" if n == total else f", {count(total)} with the constants before it")
                                + f"; a domain may have at most {count(MAX_GROUND_CONSTANTS)}", d.loc)

    def _finish(self) -> None:
        has_additive = any(d.kind in ("additiveFluent", "additiveAction") for d in self.sig.constants.values())
        if has_additive and self.sig.max_additive is None:
            d = next(d for d in self.sig.constants.values() if d.kind in ("additiveFluent", "additiveAction"))
            raise SortError("additive constants need ':- maxAdditive :: N.'", d.loc)
        self._check_ground_size()
        self.sig.finalize()
        _Validator(self.sig).run(self.program)


class _Validator:
    """Checks that need the final object sets: literal arguments and values in their sorts."""

    def __init__(self, sig: Signature) -> None:
        self.sig = sig
        self.disjoint: dict[tuple, bool] = {}

    def run(self, program: Program) -> None:
        for law in program.laws:
            for part in (law.head, law.body, law.after, law.where):
                if part is not None:
                    self.walk(part)
        for inc in program.increments:
            self.walk(inc.action)
            self.walk(inc.cond)
            self.walk(inc.target)
        for q in program.queries:
            for f, _ in q.items:
                self.walk(f)

    def walk(self, node) -> None:
        if isinstance(node, ir.Cst):
            for sort, a in zip(node.decl.argsorts, node.args):
                if isinstance(a, ir.Lit) and not isinstance(sort, (StepSort,)) and not self.sig.contains(sort, a.value):
                    raise SortError(f"'{_show(a.value)}' is not an object of sort '{sort}' "
                                    f"(argument of '{node.decl.name}')", node.loc)
                if isinstance(a, ir.Var) and not isinstance(a.sort, (StepSort, KindSort)) and \
                        not isinstance(sort, StepSort):
                    if self._disjoint(a.sort, sort):
                        raise SortError(f"variable {a.name} of sort '{a.sort}' can never be an argument of "
                                        f"sort '{sort}' of '{node.decl.name}'", a.loc)
        elif isinstance(node, ir.Atom) and isinstance(node.cst, ir.Cst) and isinstance(node.value, ir.Lit):
            dom = self.sig.objects_of(node.cst.decl.domain)
            v = node.value.value
            if v not in dom and not (v == "none" and node.cst.decl.kind in ("attribute", "abAction")):
                raise SortError(f"'{_show(v)}' is not in the domain {node.cst.decl.domain} of "
                                f"'{node.cst.decl.name}'", node.loc)
        for child in ir.children(node):
            self.walk(child)

    def _disjoint(self, var_sort: SortExpr, arg_sort: SortExpr) -> bool:
        key = (var_sort, arg_sort)
        known = self.disjoint.get(key)
        if known is None:
            mine = self.sig.objects_of(var_sort)
            known = self.disjoint[key] = bool(mine) and not set(mine) & set(self.sig.objects_of(arg_sort))
        return known
