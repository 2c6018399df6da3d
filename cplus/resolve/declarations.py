"""Declarations: sorts, objects, constants, variables and ``maxAdditive``.

They fill the signature that every later statement is read against, and they are where a
domain can ask for the most (a range of 10^9 objects, a constructor over several large
sorts), so the object counts are checked here, before anything is built.
"""
from __future__ import annotations

from cplus import ast, ir
from cplus.errors import Location, ResolveError, SortError
from cplus.limits import MAX_OBJECTS, count
from cplus.resolve.core import _KIND_ALIASES, _Scope
from cplus.resolve.terms import _Terms
from cplus.signature import ConstDecl, NamedSort, RangeSort, SortExpr


class _Declarations(_Terms):
    # ------------------------------------------------------------------ sorts, objects
    def _st_Sorts(self, stmt: ast.Sorts) -> None:
        for d in stmt.decls:
            self._check_new_sort_name(d.name, d.loc)
            self.sig.add_sort(d.name, d.loc)
            if d.parent is not None:
                if self.sig.is_subsort(d.parent, d.name) and d.parent != d.name:
                    raise SortError(f"'{d.parent} >> {d.name}' would make the sorts a cycle", d.loc)
                self.sig.add_subsort(d.parent, d.name)

    def _check_new_sort_name(self, name: str, loc: Location) -> None:
        if name in ("step", "astep", "afValue") or name in _KIND_ALIASES:
            raise SortError(f"'{name}' is a built-in name and cannot be declared as a sort", loc)
        if name[0].isupper():
            raise SortError(f"sort names start with a lower-case letter: '{name}'", loc)

    def _st_Objects(self, stmt: ast.Objects) -> None:
        for item in stmt.items:
            self._sort_info(item.sort, item.sort_loc)
            if item.sort == "boolean":
                raise SortError("the objects of 'boolean' are fixed (true, false)", item.sort_loc)
            for term in item.terms:
                for value in self._object_values(self._expand(term)):
                    self.sig.add_object(value, item.sort)

    def _object_values(self, e: ast.Expr) -> list:
        if isinstance(e, ast.Range):
            return self._range_objects(e)
        if isinstance(e, ast.Name) and not e.args:
            if e.name[0].isupper():
                raise ResolveError(f"object names start with a lower-case letter: '{e.name}'", e.loc)
            if self.sig.lookup(e.name, 0) is not None:
                raise ResolveError(f"'{e.name}' is already declared as a constant", e.loc)
            self.objects.setdefault(e.name, e.loc)
            return [e.name]
        if isinstance(e, ast.Name):
            if self.sig.lookup(e.name, len(e.args)) is not None:
                raise ResolveError(f"'{e.name}/{len(e.args)}' is already declared as a constant", e.loc)
            choices = [self._constructor_arg(a) for a in e.args]
            total = 1
            for ch in choices:
                total *= len(ch)
            self._room_for_objects(total, e.loc, f"'{e.name}(...)' declares")
            self.sig.constructors[(e.name, len(e.args))] = e.loc
            out: list = [()]
            for ch in choices:
                out = [prev + (v,) for prev in out for v in ch]
            return [(e.name,) + t for t in out]
        return [self._static_int(e)]

    def _range_objects(self, e: ast.Range) -> list:
        """The integers of a range in ``:- objects`` (an empty range declares none: warned)."""
        lo, hi = self._static_int(e.lo), self._static_int(e.hi)
        if hi < lo:
            self.diag.warn(f"the range {lo}..{hi} is empty: it declares no objects", e.loc)
            return []
        self._room_for_objects(hi - lo + 1, e.loc, f"the range {lo}..{hi} declares")
        return list(range(lo, hi + 1))

    def _room_for_objects(self, n: int, loc: Location, what: str) -> None:
        """Refuse, before building them, more objects than MAX_OBJECTS in all."""
        have = len(self.sig.object_order)
        if have + n > MAX_OBJECTS:
            raise SortError(f"{what} {count(n)} objects; a domain may declare at most {count(MAX_OBJECTS)} "
                            f"objects in all" + (f" ({count(have)} are declared already)" if have > 3 else ""), loc)

    def _constructor_arg(self, a: ast.Expr) -> list:
        a = self._expand(a)
        if isinstance(a, ast.Range):
            return self._range_objects(a)
        if isinstance(a, ast.SortRef):
            self._sort_info(a.name, a.loc)
            return list(self.sig.objects_of(NamedSort(a.name, a.star)))
        if isinstance(a, ast.Name) and not a.args and a.name in self.sig.sorts:
            return list(self.sig.objects_of(NamedSort(a.name)))
        if isinstance(a, ast.Name) and not a.args and a.name in self.objects:
            return [a.name]
        if isinstance(a, ast.Name) and not a.args:
            raise SortError(f"'{a.name}' is neither a sort nor an object", a.loc)
        term = self._term(a, _Scope())
        if isinstance(term, ir.Lit):
            return [term.value]
        raise ResolveError("a constructor argument must be a sort, a range or an object", a.loc)

    # ------------------------------------------------------------------ constants
    def _st_Constants(self, stmt: ast.Constants) -> None:
        for item in stmt.items:
            spec = item.spec
            kind = spec.kind
            domain: SortExpr
            if kind is None:
                kind, domain = "rigid", self._sort_expr(spec.domain)  # type: ignore[arg-type]
            elif kind == "attribute":
                domain = self._sort_expr(spec.domain) if spec.domain is not None else NamedSort("boolean")
            elif kind in _KIND_ALIASES:
                domain = self._sort_expr(spec.domain) if spec.domain is not None else NamedSort("boolean")
            elif spec.domain is None and kind in self.sig.sorts:
                kind, domain = "rigid", NamedSort(kind)
            elif spec.domain is None and (kind, 0) in self.macros:
                kind, domain = "rigid", self._sort_expr(ast.SortRef(spec.loc, kind))
            else:
                raise SortError(f"unknown constant kind or sort '{kind}'", spec.loc)
            if kind in ("additiveFluent", "additiveAction"):
                self._check_numeric(domain, spec.loc)
            parent = None
            if kind == "attribute":
                parent = self._attribute_parent(spec)
            for cname in item.names:
                self._declare_constant(cname, kind, domain, parent, spec.loc)

    def _check_numeric(self, domain: SortExpr, loc: Location) -> None:
        if isinstance(domain, RangeSort):
            return
        objs = self.sig.objects_of(domain)
        bad = [o for o in objs if not isinstance(o, int)]
        if bad:
            raise SortError(f"an additive constant needs a numeric domain; '{domain}' has '{bad[0]}'", loc)

    def _attribute_parent(self, spec: ast.ConstSpec) -> ConstDecl:
        p = spec.parent
        assert p is not None
        decl = self.sig.lookup(p.name, len(p.args))
        if decl is None:
            raise ResolveError(f"unknown action '{p.name}/{len(p.args)}' in 'attribute ... of'", p.loc)
        if decl.kind not in ("exogenousAction", "action", "abAction"):
            raise SortError(f"'{p.name}' is a {decl.kind}; attributes belong to actions", p.loc)
        sorts = tuple(self._sort_expr(s) for s in p.args)
        if sorts != decl.argsorts:
            raise SortError(f"the argument sorts of '{p.name}' are ({', '.join(map(str, decl.argsorts))})", p.loc)
        return decl

    def _declare_constant(self, cname: ast.ConstName, kind: str, domain: SortExpr,
                          parent: ConstDecl | None, loc: Location, auto_ab: bool = False) -> ConstDecl:
        name = cname.name
        if name[0].isupper():
            raise ResolveError(f"constant names start with a lower-case letter: '{name}'", cname.loc)
        argsorts = tuple(self._sort_expr(s) for s in cname.args)
        key = (name, len(argsorts))
        if key in self.sig.constants:
            raise ResolveError(f"constant '{name}/{len(argsorts)}' is declared twice", cname.loc)
        if key in self.sig.constructors or (not argsorts and name in self.objects):
            raise ResolveError(f"'{name}' is already declared as an object", cname.loc)
        decl = ConstDecl(name, argsorts, kind, domain, cname.loc, parent=parent, auto_ab=auto_ab,
                         order=self.const_order)
        self.const_order += 1
        if parent is not None:
            k = parent.arity
            if argsorts[:k] != parent.argsorts:
                raise SortError(f"the arguments of attribute '{name}' must begin with those of '{parent.name}'",
                                cname.loc)
            decl.parent_args = tuple(range(k))
            parent.attributes.append(decl)
        self.sig.constants[key] = decl
        return decl

    # ------------------------------------------------------------------ variables, maxAdditive
    def _st_Variables(self, stmt: ast.Variables) -> None:
        for item in stmt.items:
            sort = self._sort_expr(item.sort, for_variable=True)
            for name, loc in item.names:
                if not name[0].isupper():
                    raise ResolveError(f"variable names start with an upper-case letter: '{name}'", loc)
                old = self.variables.get(name)
                if old is not None and old.sort != sort:
                    where = f" at {old.loc}" if old.loc is not None else ""
                    raise ResolveError(f"variable {name} is declared again with another sort: '{sort}' here, "
                                       f"'{old.sort}'{where}", loc)
                self.variables[name] = ir.Var(name, sort, loc)

    def _st_MaxAdditive(self, stmt: ast.MaxAdditive) -> None:
        value = self._static_int(self._expand(stmt.value))
        if value < 0:
            raise SortError("maxAdditive must not be negative", stmt.loc)
        self.sig.max_additive = value
        self.macros[("maxAdditive", 0)] = ast.MacroDef(stmt.loc, "maxAdditive", 0, ast.Num(stmt.loc, value))
        self.measured.clear()
