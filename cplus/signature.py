"""Sorts, objects, constants and their ground instances: the signature of a domain.

Identity layers (compare clingo's symbols / program literals / solver literals):

* an **object** is a plain Python value: an ``int``, a ``str`` for a symbolic name
  (``"table"``, ``"none"``, ``"true"``), or a tuple ``("cell", 2)`` for a constructor object;
* a **constant** is a :class:`ConstDecl` (name, argument sorts, kind, domain); its **ground
  instances** are interned :class:`GroundConst` objects (``loc(d1)``), each with a small
  integer ``id``;
* a **ground atom** is a ground constant with one value of its domain; the grounder gives
  atoms integer ids and the SAT layer maps (atom, step) to solver variables.

Objects are ordered by Prolog's standard order of terms (integers < names < compound
terms), which is what ``@<`` compares and how CCALC prints argument tuples.
"""
from __future__ import annotations

from itertools import product

from cplus.errors import Location
from cplus.record import Record

__all__ = [
    "Value", "SortExpr", "NamedSort", "RangeSort", "KindSort", "StepSort",
    "ConstDecl", "GroundConst", "Signature", "FLUENT_KINDS", "ACTION_KINDS", "SIMPLE_KINDS",
    "order_key", "render_value",
]

Value = int | str | tuple

FLUENT_KINDS = frozenset({"simpleFluent", "inertialFluent", "sdFluent", "additiveFluent"})
ACTION_KINDS = frozenset({"exogenousAction", "action", "attribute", "abAction", "additiveAction",
                          "contribution"})
SIMPLE_KINDS = frozenset({"simpleFluent", "inertialFluent", "additiveFluent"})
CONSTANT_KINDS = FLUENT_KINDS | ACTION_KINDS | {"rigid"}
USER_KINDS = CONSTANT_KINDS - {"contribution"}


def order_key(v: object) -> tuple:
    """Prolog standard order: numbers < atoms < compound terms (arity, name, args)."""
    if isinstance(v, bool):  # pragma: no cover - never an object, but keep bools out
        return (0, int(v))
    if isinstance(v, int):
        return (0, v)
    if isinstance(v, str):
        return (1, v)
    if isinstance(v, GroundConst):
        return (2, len(v.args), v.decl.name, tuple(order_key(a) for a in v.args))
    if isinstance(v, tuple):
        return (2, len(v) - 1, v[0], tuple(order_key(a) for a in v[1:]))
    raise TypeError(f"not a C+ value: {v!r}")


def render_value(v: Value) -> str:
    if isinstance(v, tuple):
        return f"{v[0]}({','.join(render_value(a) for a in v[1:])})"
    if isinstance(v, GroundConst):
        return v.text
    return str(v)


# --------------------------------------------------------------------------- sorts


class NamedSort(Record):
    """A declared (or built-in) sort; ``star`` adds the object ``none``."""

    _fields = ("name", "star")
    __slots__ = _fields

    name: str
    star: bool

    def __init__(self, name: str, star: bool = False) -> None:
        self.name = name
        self.star = star

    def __str__(self) -> str:
        return self.name + ("*" if self.star else "")


class RangeSort(Record):
    """An anonymous integer sort ``lo..hi``."""

    _fields = ("lo", "hi", "star")
    __slots__ = _fields

    lo: int
    hi: int
    star: bool

    def __init__(self, lo: int, hi: int, star: bool = False) -> None:
        self.lo = lo
        self.hi = hi
        self.star = star

    def __str__(self) -> str:
        return f"{self.lo}..{self.hi}"


class KindSort(Record):
    """Variables over a constant kind (``A :: exogenousAction``): Boolean ground constants."""

    _fields = ("kind",)
    __slots__ = _fields

    kind: str

    def __init__(self, kind: str) -> None:
        self.kind = kind

    def __str__(self) -> str:
        return self.kind


class StepSort(Record):
    """``step`` (0..maxstep) or ``astep`` (0..maxstep-1): only known per horizon."""

    _fields = ("action",)
    __slots__ = _fields

    action: bool

    def __init__(self, action: bool = False) -> None:
        self.action = action

    def __str__(self) -> str:
        return "astep" if self.action else "step"


SortExpr = NamedSort | RangeSort | KindSort | StepSort


class SortInfo:
    name: str
    loc: Location | None
    parents: list[str]
    children: list[str]
    objects: list[Value]
    members: set   # the same objects, for constant-time membership

    def __init__(
            self,
            name: str,
            loc: Location | None,
            parents: list[str] | None = None,
            children: list[str] | None = None,
            objects: list[Value] | None = None,
            members: set | None = None) -> None:
        self.name = name
        self.loc = loc
        self.parents = [] if parents is None else parents
        self.children = [] if children is None else children
        self.objects = [] if objects is None else objects
        self.members = set() if members is None else members

    def __repr__(self) -> str:
        return f"SortInfo(name={self.name!r}, loc={self.loc!r}, ...)"


# --------------------------------------------------------------------------- constants


class ConstDecl:
    """A declared constant ``name(argsorts) :: kind(domain)``."""

    name: str
    argsorts: tuple[SortExpr, ...]
    kind: str
    domain: SortExpr
    loc: Location | None
    parent: ConstDecl | None
    parent_args: tuple[int, ...]   # attribute: positions of the parent's arguments
    hidden: bool                # internal constants (contributions, ...)
    auto_ab: bool               # declared by an `unless` clause
    abnormal: bool              # named by an `unless` clause (auto-declared or not)
    order: int                      # declaration order
    instances: dict[tuple, GroundConst]
    attributes: list[ConstDecl]

    def __init__(
            self,
            name: str,
            argsorts: tuple[SortExpr, ...],
            kind: str,
            domain: SortExpr,
            loc: Location | None,
            parent: ConstDecl | None = None,
            parent_args: tuple[int, ...] = (),
            hidden: bool = False,
            auto_ab: bool = False,
            order: int = 0,
            instances: dict[tuple, GroundConst] | None = None,
            attributes: list[ConstDecl] | None = None) -> None:
        self.name = name
        self.argsorts = argsorts
        self.kind = kind
        self.domain = domain
        self.loc = loc
        self.parent = parent
        self.parent_args = parent_args
        self.hidden = hidden
        self.auto_ab = auto_ab
        self.abnormal = auto_ab
        self.order = order
        self.instances = {} if instances is None else instances
        self.attributes = [] if attributes is None else attributes

    @property
    def arity(self) -> int:
        return len(self.argsorts)

    @property
    def is_fluent(self) -> bool:
        return self.kind in FLUENT_KINDS

    @property
    def is_action(self) -> bool:
        return self.kind in ACTION_KINDS

    def __repr__(self) -> str:
        return f"ConstDecl({self.name}/{self.arity}:{self.kind})"


class GroundConst:
    """A ground constant instance such as ``loc(d1)``, interned per signature: there is one
    object per instance, so identity is equality (and hashing stays in C)."""

    __slots__ = ("decl", "args", "id", "text", "domain", "boolean")

    def __init__(self, decl: ConstDecl, args: tuple, ident: int, domain: tuple) -> None:
        self.decl = decl
        self.args = args
        self.id = ident
        self.text = decl.name if not args else f"{decl.name}({','.join(render_value(a) for a in args)})"
        self.domain = domain
        self.boolean = domain == ("true", "false")

    def __repr__(self) -> str:
        return self.text

    def __str__(self) -> str:
        return self.text


class Signature:
    """Symbol tables built by :mod:`cplus.resolve`; ground instances after :meth:`finalize`."""

    def __init__(self) -> None:
        self.sorts: dict[str, SortInfo] = {}
        self.constants: dict[tuple[str, int], ConstDecl] = {}
        self.object_order: dict[Value, int] = {}
        self.constructors: dict[tuple[str, int], Location | None] = {}
        self.max_additive: int | None = None
        self.ground: list[GroundConst] = []
        self.made: dict = {}
        """Internal constants made by grounding (additive contributions), by a key of the
        grounder's: grounding the program again reuses them instead of adding more."""
        self.finalized = False
        self._sort_cache: dict[SortExpr, tuple] = {}
        self.add_sort("boolean", None)
        self.add_object("true", "boolean")
        self.add_object("false", "boolean")

    # -- declarations -------------------------------------------------------------
    def add_sort(self, name: str, loc: Location | None) -> SortInfo:
        info = self.sorts.get(name)
        if info is None:
            info = self.sorts[name] = SortInfo(name, loc)
        return info

    def add_subsort(self, parent: str, child: str) -> None:
        p, c = self.sorts[parent], self.sorts[child]
        if child not in p.children:
            p.children.append(child)
            c.parents.append(parent)
        self._sort_cache.clear()

    def add_object(self, value: Value, sort: str) -> None:
        if value not in self.object_order:
            self.object_order[value] = len(self.object_order)
        info = self.sorts[sort]
        if value not in info.members:
            info.members.add(value)
            info.objects.append(value)
            if self._sort_cache:
                self._sort_cache.clear()

    def is_subsort(self, child: str, parent: str) -> bool:
        if child == parent:
            return True
        seen, todo = set(), [child]
        while todo:
            s = todo.pop()
            for p in self.sorts[s].parents:
                if p == parent:
                    return True
                if p not in seen:
                    seen.add(p)
                    todo.append(p)
        return False

    # -- sort extensions ----------------------------------------------------------
    def objects_of(self, sort: SortExpr) -> tuple:
        """The objects of a sort, subsorts included, in declaration order."""
        cached = self._sort_cache.get(sort)
        if cached is not None:
            return cached
        if isinstance(sort, NamedSort):
            seen: dict[Value, None] = {}
            todo = [sort.name]
            visited = set()
            while todo:
                s = todo.pop(0)
                if s in visited:
                    continue
                visited.add(s)
                info = self.sorts[s]
                for o in info.objects:
                    seen.setdefault(o, None)
                todo.extend(info.children)
            objs = sorted(seen, key=self.object_order.__getitem__)
            if sort.name == "boolean":
                objs = ["true", "false"]
            if sort.star and "none" not in seen:
                objs.append("none")
            result = tuple(objs)
        elif isinstance(sort, RangeSort):
            result = tuple(range(sort.lo, sort.hi + 1)) + (("none",) if sort.star else ())
        elif isinstance(sort, KindSort):
            result = tuple(g for g in self.ground if g.decl.kind == sort.kind and g.boolean  # type: ignore[misc]
                           and not g.decl.hidden)
        else:
            raise TypeError(f"the objects of {sort} depend on maxstep")
        if self.finalized or not isinstance(sort, KindSort):
            self._sort_cache[sort] = result
        return result

    def contains(self, sort: SortExpr, value: object) -> bool:
        if isinstance(sort, RangeSort):
            return (isinstance(value, int) and sort.lo <= value <= sort.hi) or (sort.star and value == "none")
        return value in self._membership(sort)

    def _membership(self, sort: SortExpr) -> frozenset:
        key = ("members", sort)
        cached = self._sort_cache.get(key)  # type: ignore[call-overload]
        if cached is None:
            cached = frozenset(self.objects_of(sort))
            self._sort_cache[key] = cached  # type: ignore[assignment, index]
        return cached

    # -- ground instances ---------------------------------------------------------
    def finalize(self) -> None:
        """Enumerate every constant's ground instances (objects are final now), after
        checking that they fit in memory (see :mod:`cplus.limits`)."""
        self.ground = []
        self._sort_cache.clear()
        decls = sorted(self.constants.values(), key=lambda d: d.order)
        self._check_size(decls)
        for decl in decls:
            self._instantiate(decl)
        self.finalized = True
        self._sort_cache.clear()

    def _check_size(self, decls: list[ConstDecl]) -> None:
        from cplus.limits import ATOM_BYTES, INSTANCE_BYTES, memory_budget, too_large
        from cplus.limits import count as fmt
        total = 0
        biggest: tuple[int, ConstDecl | None, list[int]] = (0, None, [])
        for decl in decls:
            sizes = [len(self.objects_of(s)) for s in decl.argsorts]
            count = 1
            for n in sizes:
                count *= n
            values = len(self.objects_of(decl.domain)) if decl.domain is not None else 2
            cost = count * (INSTANCE_BYTES + max(values, 1) * ATOM_BYTES)
            total += cost
            if cost > biggest[0]:
                biggest = (cost, decl, sizes)
        if total > memory_budget():
            _, big, sizes = biggest
            assert big is not None
            count = 1
            for n in sizes:
                count *= n
            shape = " x ".join(fmt(n) for n in sizes)
            from cplus.errors import GroundingError
            raise GroundingError(too_large(f"the constant '{big.name}' has {fmt(count)} ground instances "
                                           f"({shape} arguments)", total), big.loc)

    def _instantiate(self, decl: ConstDecl) -> None:
        decl.instances = {}
        domain = self.objects_of(decl.domain)
        if decl.kind == "attribute" or (decl.kind == "abAction" and domain != ("true", "false")):
            if "none" not in domain:
                domain = domain + ("none",)
        arg_values = [self.objects_of(s) for s in decl.argsorts]
        for args in product(*arg_values):
            g = GroundConst(decl, tuple(args), len(self.ground), domain)
            decl.instances[g.args] = g
            self.ground.append(g)

    def add_hidden_instance(self, decl: ConstDecl, args: tuple, domain: tuple) -> GroundConst:
        """A ground instance of an internal constant created during grounding."""
        g = GroundConst(decl, args, len(self.ground), domain)
        decl.instances[args] = g
        self.ground.append(g)
        return g

    def lookup(self, name: str, arity: int) -> ConstDecl | None:
        return self.constants.get((name, arity))

    def constants_named(self, name: str) -> list[ConstDecl]:
        return [d for (n, _), d in self.constants.items() if n == name]
