"""C+ planning in the style of CCALC (the Causal Calculator).

Identity layers, from source to solver:

* a **constant** (``loc(disk)``) is declared in the domain; its **ground instances**
  (``loc(d1)``) are :class:`~cplus.signature.GroundConst` objects;
* a **ground atom** is a ground instance with a value (``loc(d1)=table``), an integer id in
  the :class:`~cplus.ground.atoms.AtomTable`; a Boolean constant has one atom;
* a **template literal** pairs an atom with a step slot (now, next, rigid); the SAT layer
  turns (atom, step) into a **solver variable**.

The public API is :class:`Domain`:

>>> from cplus import Domain
>>> Domain.from_text(":- constants p :: simpleFluent. :- query maxstep :: 0.").solve().maxstep
0
"""
from __future__ import annotations

__all__ = ["Domain", "CPlusError", "History", "QueryResult", "PlanStatus", "OptimalResult", "Optimum"]


def __getattr__(name: str):  # lazy: `cplus brick` should not load the solver stack
    if name == "Domain":
        from cplus.api import Domain
        return Domain
    if name == "CPlusError":
        from cplus.errors import CPlusError
        return CPlusError
    if name == "History":
        from cplus.history import History
        return History
    if name in ("QueryResult", "PlanStatus"):
        from cplus import planner
        return getattr(planner, name)
    if name in ("OptimalResult", "Optimum"):     # Domain.minimize's result
        from cplus.sat import optimize
        return getattr(optimize, name)
    raise AttributeError(name)
