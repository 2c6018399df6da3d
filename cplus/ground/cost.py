"""What grounding a law will cost, estimated before it starts.

Two numbers matter, and a law is refused (located, with the number) when either is too
large (:mod:`cplus.limits`):

* its *instances*, the bindings that pass its conditions: each is a rule in memory
  (:func:`sampled_instances`: the share of a fixed random sample of bindings that passes);
* its *tries*, every value :func:`~cplus.ground.compile.bind` tries, passing or not: a law
  with one instance can still mean ten billion tries (``where X * Y = 7`` over ``0..99999``)
  and hang.  An upper bound (:func:`tries_bound`, the prefix products of the levels'
  sizes) settles most laws at once; when it is over the limit, random probes down the tree
  of tries (:func:`probed_tries`, Knuth's estimate of a backtrack tree's size) estimate
  the tries that the conditions leave.

The grounder also counts tries as it goes and stops a law at the limit, so an estimate
that was too low (a condition that almost never passes, so that no probe passes it) costs
time up to the limit, never a hang.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from cplus.errors import GroundingError

__all__ = ["tries_bound", "probed_tries", "sampled_instances", "Level", "bind_levels", "options_of", "passing"]

Level = tuple[str, Callable[[dict], Sequence], list[Callable[[dict], bool]]]
"""One level of a law's binding: the variable, ``options(env)`` (the values tried for it
given the variables bound before) and the tests a value must pass to go deeper."""

PROBES = 4096


def tries_bound(sizes: Sequence[int]) -> int:
    """Most values tried over levels of these sizes (every binding passing every test)."""
    total, prefix = 0, 1
    for n in sizes:
        prefix *= n
        total += prefix
    return total


def probed_tries(levels: Sequence[Level], probes: int = PROBES) -> int:
    """Estimated values tried over ``levels``, from ``probes`` random walks down the tree of
    tries from a fixed seed: a walk picks one of the options at each level, uniformly, and
    stops where it fails a test; the options met, weighted by the product of the option
    counts above them, are an unbiased estimate of the tree's size."""
    import random  # here: few laws need an estimate, and every command would import it
    rnd = random.Random(0)
    total = 0
    for _ in range(probes):
        env: dict = {}
        weight = 1
        for name, options, tests in levels:
            try:
                opts = options(env)
            except GroundingError:
                break
            n = len(opts)
            if n == 0:
                break
            total += weight * n
            weight *= n
            env[name] = opts[rnd.randrange(n)]
            if not _passes(tests, env):
                break
    return total // probes


def bind_levels(levels: list, solvers: list) -> tuple[list[int], Callable[[], list[Level]]]:
    """The levels of :func:`~cplus.ground.compile.bind` (its ``binding_levels`` and their
    solvers, :mod:`cplus.ground.equations`): the most values each tries per binding above
    it (1 where an equation fixes the variable), and a function that makes the levels for
    :func:`probed_tries` (only needed when the sizes' bound is too large)."""
    sizes = [len(dom) if solve is None else min(1, len(dom)) for (_, dom, _), solve in zip(levels, solvers)]

    def probe() -> list[Level]:
        return [(name, options_of(dom, solve), [passing(fn) for fn in fl])
                for (name, dom, fl), solve in zip(levels, solvers)]
    return sizes, probe


def passing(fn: Callable) -> Callable[[dict], bool]:
    """A test of :data:`Level` from a filter ``fn(env, time)`` of :func:`~cplus.ground.compile.bind`."""
    return lambda env: fn(env, 0) is True


def options_of(dom: Sequence, solve) -> Callable[[dict], Sequence]:
    """``options(env)``: the values of ``dom`` tried at a level with the solver ``solve``."""
    if solve is None:
        return lambda env: dom
    member = frozenset(dom)

    def options(env: dict) -> Sequence:
        got = solve(env)
        return dom if got is None else [v for v in got if v in member]
    return options


def _passes(tests: list[Callable[[dict], bool]], env: dict) -> bool:
    try:
        return all(t(env) for t in tests)
    except GroundingError:
        return False


def sampled_instances(doms: Mapping[str, Sequence], filters: list, cells: int, samples: int = PROBES) -> int:
    """Estimated number of bindings of the variables' domains ``doms`` (``cells`` of them)
    that pass every filter ``(fn, variables)``, from a fixed random sample."""
    import random
    rnd = random.Random(0)
    names = list(doms)
    passed = 0
    for _ in range(samples):
        env = {n: rnd.choice(doms[n]) for n in names}
        try:
            ok = all(fn(env, 0) is True for fn, _ in filters)
        except GroundingError:
            ok = False
        passed += ok
    return cells * passed // samples
