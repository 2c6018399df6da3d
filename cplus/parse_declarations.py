"""The builder's rules for C+ declarations and directives: sorts, objects, constants,
variables, macros, include, show/hide, query and nmquery, maxAdditive.

One of the two halves of :class:`cplus.parser._Builder` (one method per grammar rule), kept
apart from the laws and formulas (:mod:`cplus.parse_formulas`) so that each half reads on
its own.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from cplus import ast
from cplus.errors import CPlusSyntaxError
from cplus.lalr import Token
from cplus.parse_tree import _TreeWalk
from cplus.signature import USER_KINDS

if TYPE_CHECKING:
    pass


def _as_sort(e):
    """A sort written in a declaration, as the grammar reads it (an expression), classified:
    ``s`` and ``s*`` and ``s+none`` become :class:`ast.SortRef`, ranges stay ranges, and
    anything else (a macro call) is left for the resolver to expand."""
    if isinstance(e, ast.Name) and not e.args:
        return ast.SortRef(e.loc, e.name)
    if isinstance(e, ast.Binary) and e.op == "+" and isinstance(e.left, ast.Name) and not e.left.args \
            and isinstance(e.right, ast.Name) and e.right.name == "none" and not e.right.args:
        return ast.SortRef(e.loc, e.left.name, True)
    return e

class _DeclarationRules(_TreeWalk):
    """Declarations and directives: one method per grammar rule, given the rule's meta and
    its children's values."""

    # -------------------------------------------------------------- statements
    def statement(self, meta, ch):
        return ch[0]

    def noconcurrency(self, meta, ch):
        return ast.NoConcurrency(self._loc(meta), str(ch[0]) == "strong_noconcurrency")

    def unknown_directive(self, meta, ch):
        raise CPlusSyntaxError(f"unknown directive ':- {ch[0]}'", self._tloc(ch[0]))

    def sorts(self, meta, ch):
        """``a >> b >> (c; d >> e)``: each sort with its parent, depth first, without recursion."""
        decls: list[ast.SortDecl] = []
        todo: list = [("item", item, None) for item in reversed(ch)]
        while todo:
            what, thing, parent = todo.pop()
            if what == "decl":
                decls.append(ast.SortDecl(self._tloc(thing), str(thing), parent))
                continue
            name_tok, groups = thing
            steps: list = [("decl", name_tok, parent)]
            current = str(name_tok)
            for group in groups:
                if group[0] == "leaf":
                    steps.append(("decl", group[1], current))
                    current = str(group[1])
                else:
                    steps.extend(("item", sub, current) for sub in group[1])
            todo.extend(reversed(steps))
        return ast.Sorts(self._loc(meta), tuple(decls))

    def sort_item(self, meta, ch):
        return (ch[0], ch[1:])

    def sort_leaf(self, meta, ch):
        return ("leaf", ch[0])

    def sort_many(self, meta, ch):
        return ("many", ch)

    def objects(self, meta, ch):
        return ast.Objects(self._loc(meta), tuple(ch))

    def object_item(self, meta, ch):
        *terms, sort = ch
        return ast.ObjectItem(self._loc(meta), tuple(terms), str(sort), self._tloc(sort))

    def constants(self, meta, ch):
        return ast.Constants(self._loc(meta), tuple(ch))

    def constant_item(self, meta, ch):
        *names, spec = ch
        return ast.ConstantItem(self._loc(meta), tuple(names), spec)

    def const_name(self, meta, ch):
        return ast.ConstName(self._loc(meta), str(ch[0]), tuple(_as_sort(a) for a in ch[1:]))

    def plain_spec(self, meta, ch):
        """``c :: K``, ``c :: K(D)``, ``c :: D``: K a constant kind (D defaults to boolean), D a
        sort, a range, ``s*`` or ``s+none`` (then c is rigid), or a macro call giving one."""
        spec = ch[0]
        loc = self._loc(meta)
        if isinstance(spec, ast.Name) and not spec.args:
            return ast.ConstSpec(loc, spec.name, None)   # a kind, a sort or a macro: the resolver knows
        if isinstance(spec, ast.Name) and spec.name in USER_KINDS:
            if len(spec.args) != 1:
                raise CPlusSyntaxError(f"'{spec.name}' takes one domain: write '{spec.name}(D)'", spec.loc)
            return ast.ConstSpec(loc, spec.name, _as_sort(spec.args[0]))
        return ast.ConstSpec(loc, None, _as_sort(spec))

    def attribute_spec(self, meta, ch):
        domain = _as_sort(ch[0]) if not isinstance(ch[0], Token) else None
        rest = ch[1:] if domain is not None else ch
        parent_tok, *parent_args = rest
        parent = ast.ConstName(self._tloc(parent_tok), str(parent_tok), tuple(_as_sort(a) for a in parent_args))
        return ast.ConstSpec(self._loc(meta), "attribute", domain, parent)

    def star_sort(self, meta, ch):
        return ast.SortRef(self._tloc(ch[0]), str(ch[0])[:-1], True)

    def range(self, meta, ch):
        return ast.Range(self._loc(meta), ch[0], ch[1])

    def variables(self, meta, ch):
        return ast.Variables(self._loc(meta), tuple(ch))

    def variable_item(self, meta, ch):
        *names, sort = ch
        return ast.VariableItem(self._loc(meta), tuple((str(t), self._tloc(t)) for t in names), _as_sort(sort))

    def macros(self, meta, ch):
        return ast.Macros(self._loc(meta), tuple(ch))

    def macro_item(self, meta, ch):
        name, *params, body = ch
        for k, p in enumerate(params, start=1):
            if int(str(p)[1:]) != k:
                raise CPlusSyntaxError(f"macro parameters must be #1, #2, ... in order; found {p}",
                                       self._tloc(p))
        return ast.MacroDef(self._loc(meta), str(name), len(params), body)

    def include(self, meta, ch):
        return ast.Include(self._loc(meta), tuple(ch))

    def include_quoted(self, meta, ch):
        return (str(ch[0])[1:-1], self._tloc(ch[0]))

    def include_name(self, meta, ch):
        return (str(ch[0]), self._tloc(ch[0]))

    def show(self, meta, ch):
        return self._showhide(meta, ch, False)

    def hide(self, meta, ch):
        return self._showhide(meta, ch, True)

    def _showhide(self, meta, ch, hide):
        all_ = any(c == "all" for c in ch)
        pats = tuple(c for c in ch if c != "all")
        return ast.ShowHide(self._loc(meta), hide, all_, pats)

    def show_all(self, meta, ch):
        return "all"

    def show_pattern(self, meta, ch):
        if len(ch) == 1:
            return ch[0]
        if str(ch[1]) != "=":
            raise CPlusSyntaxError("a show/hide pattern is an atom 'c(args)' or 'c(args)=v'",
                                   self._tloc(ch[1]))
        return ast.Binary(self._loc(meta), "=", ch[0], ch[2])

    def show_negative(self, meta, ch):
        return ast.Unary(self._loc(meta), "not", ch[0])

    def show_stamped_pattern(self, meta, ch):
        """``t: c(args)``: CCALC's show specification of one step (``process_show_internal``)."""
        return ast.Stamp(self._loc(meta), ch[0], self.show_pattern(meta, ch[1:]))

    def show_stamped_negative(self, meta, ch):
        return ast.Stamp(self._loc(meta), ch[0], ast.Unary(self._loc(meta), "not", ch[1]))

    def query(self, meta, ch):
        return ast.Query(self._loc(meta), tuple(ch))

    def nmquery(self, meta, ch):
        return ast.Query(self._loc(meta), tuple(ch), nm=True)

    def nm_caused(self, meta, ch):
        return ast.QueryRule(self._loc(meta), ch[0], ch[1][1] if len(ch) > 1 else None, False)

    def nm_default(self, meta, ch):
        return ast.QueryRule(self._loc(meta), ch[0], ch[1][1] if len(ch) > 1 else None, True)

    def nm_fact(self, meta, ch):
        return ast.QueryRule(self._loc(meta), ch[0], None, False)

    def nm_rule(self, meta, ch):
        """CCALC's ``H <= B`` (also ``H <- B``): ``caused H if B``."""
        return ast.QueryRule(self._loc(meta), ch[0], ch[2], False)

    def nm_constraint(self, meta, ch):
        """CCALC's ``<= B``: ``caused false if B``."""
        return ast.QueryRule(self._loc(meta), ast.Name(self._tloc(ch[0]), "false"), ch[1], False)

    def nm_rule_rightwards(self, meta, ch):
        """CCALC's ``B => H``: ``caused H if B``."""
        return ast.QueryRule(self._loc(meta), ch[2], ch[0], False)

    def q_label(self, meta, ch):
        return ast.QueryLabel(self._loc(meta), ch[0])

    def q_maxstep(self, meta, ch):
        lo, hi = ch[0]
        return ast.QueryMaxstep(self._loc(meta), lo, hi)

    def ms_exact(self, meta, ch):
        return (ch[0], ch[0])

    def ms_range(self, meta, ch):
        hi = ch[1]
        if isinstance(hi, ast.Name) and hi.name == "infinity" and not hi.args:
            hi = None
        return (ch[0], hi)

    def q_formula(self, meta, ch):
        return ast.QueryItem(self._loc(meta), ch[0])

    def max_additive(self, meta, ch):
        value = ch[-1]
        if len(ch) == 2 and str(ch[0]) != "=":
            raise CPlusSyntaxError("write ':- maxAdditive :: N.'", self._tloc(ch[0]))
        return ast.MaxAdditive(self._loc(meta), value)

