"""The resolver is one object made of mixins, one per kind of statement (cplus/resolve/): a
method name defined in two unrelated mixins would silently hide one behind the other in the
MRO (a query's ``_keyword`` once shadowed the show statement's)."""
from __future__ import annotations

from cplus.resolve import _Resolver


def test_no_two_statement_resolvers_define_the_same_method():
    mixins = [c for c in _Resolver.__mro__[1:] if c is not object]
    methods = {c: {n for n, v in vars(c).items() if callable(v) and not (n.startswith("__") and n.endswith("__"))}
               for c in mixins}
    clashes = sorted(f"{name}: {a.__name__} and {b.__name__}"
                     for i, a in enumerate(mixins) for b in mixins[i + 1:]
                     if not (issubclass(a, b) or issubclass(b, a))
                     for name in methods[a] & methods[b])
    assert not clashes, clashes
