"""Random C+ planning instances in CCALC's language, for benchmarks nobody tuned for.

    python bench/gen_instances.py OUT_DIR [--count 30] [--seed S] [--family blocks,hanoi,...]

Families: blocks worlds of 15 to 40 blocks (concurrent moves, as the corpus's bw-15), the
spacecraft of the additive-fluents paper (random bounds, jets and forces), the ferryman
(random numbers of sheep and wolves and boat capacity), Hanoi (3 to 6 disks on 3 or 4 pegs,
from a random legal position) and a car on a road as a discretised hybrid automaton (random
road length, speed step, clock and school zone: integer arithmetic in ``where`` clauses).

**Why every instance has a plan.**  Each generator simulates its domain's laws in Python.  The
blocks world, the spacecraft and the car take a random walk of ``k`` legal steps from the
initial state (the blocks mostly in a chain, each move onto the block moved before, so that
the steps cannot all happen at once); the goal is (part of) the state the walk ends in and
the query's range is ``0..k``: the walk itself is a plan, so a shortest plan exists inside the
range, perhaps shorter than ``k``.  The ferryman and Hanoi have small state spaces: a
breadth-first search from the start gives every state's distance, and the goal is a random
state in the farther half; the query's range ends at its distance, which is then the known
shortest length (``Instance.length``).  Planners must agree on the length.  The files are written with ``&`` as the conjunction (the peer's translator
rejects CCALC's `` , ``) and without Cplus2ASP-only blocks, so both planners read them as is.

Everything is a function of the seed: ``draw(seed, count)`` gives the same instances on every
machine, and an instance's name (``family-size-s<seed>``) is enough to make it again with
``instance(name)``.  The sizes are chosen so that a planner takes roughly 0.05 to 10 seconds.
"""
from __future__ import annotations

import argparse
import random
import secrets
import sys
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar


@dataclass(frozen=True)
class Instance:
    """One generated C+ file: its name, family, text, and what is known of its shortest plan."""
    name: str
    family: str
    text: str
    walk: int                   # a plan of this length exists; the query's maxstep range is 0..walk
    length: int | None = None   # the shortest plan's length, when the generator searched the whole space

    def write(self, folder: Path) -> Path:
        path = Path(folder) / f"{self.name}.cp"
        path.write_text(self.text)
        return path


# ------------------------------------------------------------------------------------- search


State = TypeVar("State", bound=Hashable)


def _distances(start: State, successors: Callable[[State], list[State]]) -> dict[State, int]:
    """Breadth-first distances from ``start`` over a small state space (one action a step)."""
    dist = {start: 0}
    frontier = [start]
    while frontier:
        nxt = []
        for st in frontier:
            for succ in successors(st):
                if succ not in dist:
                    dist[succ] = dist[st] + 1
                    nxt.append(succ)
        frontier = nxt
    return dist


def _far_state(dist: dict[State, int], rng: random.Random, cap: int | None = None) -> State:
    """A random state in the farther half of the reachable ones, at most ``cap`` away (never the start)."""
    top = min(max(dist.values()), cap or 10 ** 9)
    floor = max(1, top // 2)
    return rng.choice(sorted((st for st, d in dist.items() if floor <= d <= top), key=repr))


# ------------------------------------------------------------------------------------- blocks world


def _tower_state(blocks: list[str], rng: random.Random) -> dict[str, str]:
    """A random arrangement of the blocks in towers: block -> what it stands on."""
    order = blocks[:]
    rng.shuffle(order)
    loc: dict[str, str] = {}
    below = "table"
    for b in order:
        if below != "table" and rng.random() < 0.3:
            below = "table"
        loc[b] = below
        below = b
    return loc


def blocks_world(seed: int) -> Instance:
    """n blocks (15..40), random towers, goal: the state after a random walk of single moves (mostly a chain)."""
    rng = random.Random(seed)
    n = rng.randint(15, 40)
    names = [f"b{i}" for i in range(1, n + 1)]
    start = _tower_state(names, rng)
    k = rng.randint(4, 10) if n <= 25 else rng.randint(3, 5) if n <= 32 else rng.randint(3, 4)  # the peer: < 10 s
    loc = dict(start)
    moved = 0
    last = None
    while moved < k or loc == start:
        moved += 1
        clear = [b for b in names if b not in loc.values()]
        b = rng.choice([c for c in clear if c != last] or clear)
        if last is not None and last != b and rng.random() < 0.75:
            dest = last          # a chain: each move waits for the one before, so plans are not all one step
        else:
            targets = ["table"] * 3 + [c for c in clear if c != b]
            dest = rng.choice([t for t in targets if t != loc[b]] or ["table"])
        loc[b], last = dest, b
    k = moved

    def state(s: dict[str, str]) -> str:
        return " & ".join(f"loc({b}) = {s[b]}" for b in names)
    text = f"""% random blocks world: {n} blocks, goal after a walk of {k} moves (bench/gen_instances.py, seed {seed})
:- sorts location >> block.
:- objects table :: location; {', '.join(names)} :: block.
:- constants
  loc(block) :: inertialFluent(location);
  move(block) :: exogenousAction;
  destination(block) :: attribute(location) of move(block).
:- variables B, B1 :: block; L :: location.

move(B) causes loc(B) = L if destination(B) = L.
nonexecutable move(B) if loc(B1) = B.
nonexecutable move(B) if destination(B) = loc(B1) & destination(B) \\= table.
nonexecutable move(B) & move(B1) if destination(B) = B1.
constraint loc(B) = loc(B1) ->> loc(B) = table where B @< B1.

:- query
  label :: 0;
  maxstep :: 0..{k};
  0: {state(start)};
  maxstep: {state(loc)}.
"""
    return Instance(f"bw-{n}-s{seed}", "blocks", text, k)


# ------------------------------------------------------------------------------------- spacecraft


def spacecraft(seed: int) -> Instance:
    """The additive spacecraft: positions and velocities in -M..M, J jets; goal after a random walk."""
    rng = random.Random(seed)
    m = rng.randint(8, 16)
    jets = rng.randint(1, 2)
    max_force = 2 if jets == 1 else rng.randint(1, 2)   # one jet of force 1 could never change a velocity
    axes = ("x", "y", "z")
    want = rng.randint(2, 4)
    pos = {a: rng.randint(-m // 2, m // 2) for a in axes}
    vel = {a: 0 for a in axes}
    start = (dict(pos), dict(vel))
    steps = stuck = 0
    while steps < want or (pos, vel) == start:
        if stuck > 100 or steps > want + 2:     # a dead end (too fast near a bound), or back at the start
            pos, vel, steps, stuck = dict(start[0]), dict(start[1]), 0, 0
        stuck += 1
        firing = [j for j in range(jets) if rng.random() < 0.7]
        forces = {a: sum(rng.randint(-max_force, max_force) for _ in firing) for a in axes}
        new_vel = {a: vel[a] + forces[a] for a in axes}
        # pos is caused only when V + V1 is even and the new position stays in range
        new_pos = {a: pos[a] + (vel[a] + new_vel[a]) // 2 for a in axes}
        if all((vel[a] + new_vel[a]) % 2 == 0 and abs(new_vel[a]) <= m and abs(new_pos[a]) <= m for a in axes):
            pos, vel, steps, stuck = new_pos, new_vel, steps + 1, 0
    k = steps

    def state(p: dict[str, int], v: dict[str, int]) -> str:
        return " & ".join([f"pos({a}) = {p[a]}" for a in axes] + [f"vel({a}) = {v[a]}" for a in axes])
    jet_names = ", ".join(f"jet{j + 1}" for j in range(jets))
    text = f"""% random spacecraft: integers -{m}..{m}, {jets} jet(s), forces up to {max_force}, goal after a walk of {k} steps
% (bench/gen_instances.py, seed {seed}); the laws of "Describing Additive Fluents in C+", Section 7
:- maxAdditive :: {m}.
:- sorts integer; axis; jet.
:- objects
  -maxAdditive..maxAdditive :: integer;
  x, y, z :: axis;
  {jet_names} :: jet.
:- variables Ax :: axis; J :: jet; V, V1, P :: integer.
:- constants
  pos(axis) :: simpleFluent(integer);
  vel(axis) :: additiveFluent(integer);
  fire(jet) :: exogenousAction;
  force(jet, axis) :: attribute(integer) of fire(jet).

fire(J) increments vel(Ax) by V if force(J, Ax) = V & V \\= 0.
caused pos(Ax) = P + ((V + V1) // 2) if vel(Ax) = V1
  after vel(Ax) = V & pos(Ax) = P where (V + V1) mod 2 == 0 &
                                         P + ((V + V1) // 2) >= -maxAdditive &
                                         P + ((V + V1) // 2) =< maxAdditive.
nonexecutable fire(J) if abs(V) > {max_force} & force(J, Ax) = V.

:- query
  label :: 0;
  maxstep :: 0..{k};
  0: {state(*start)};
  maxstep: {state(pos, vel)}.
"""
    return Instance(f"spacecraft-{m}-{jets}-s{seed}", "spacecraft", text, k)


# ------------------------------------------------------------------------------------- ferryman


def _ferry_safe(num: int, sheep: int, wolves: int) -> bool:
    """The corpus's two constraints: wolves never outnumber sheep on a bank that has sheep."""
    if 0 < sheep < wolves:
        return False
    return not (sheep < num and wolves < sheep)


def _ferry_next(num: int, cap: int, st: tuple[int, int, bool]) -> list[tuple[int, int, bool]]:
    """The states one crossing away (a step has at most one crossing: two would cause two counts)."""
    sheep, wolves, boat = st
    out = []
    for s in range(cap + 1):
        for w in range(cap + 1 - s):
            ns, nw = (sheep - s, wolves - w) if boat else (sheep + s, wolves + w)
            if s + w and 0 <= ns <= num and 0 <= nw <= num and _ferry_safe(num, ns, nw):
                out.append((ns, nw, not boat))
    return out


def ferryman(seed: int) -> Instance:
    """NUM sheep and NUM wolves, a boat for CAPACITY; goal: a state far from the start (its distance known)."""
    rng = random.Random(seed)
    num = rng.randint(4, 9)
    cap = rng.randint(2, 4)
    start = (num, num, True)
    dist = _distances(start, lambda st: _ferry_next(num, cap, st))
    sheep, wolves, boat = _far_state(dist, rng)
    k = dist[(sheep, wolves, boat)]
    text = f"""% random ferryman: {num} sheep and {num} wolves, a boat for {cap}, goal {k} crossings away
% (bench/gen_instances.py, seed {seed}); the laws of the corpus's ferryman benchmark
:- sorts int; type.
:- macros NUM -> {num}; CAPACITY -> {cap}.
:- objects 0..NUM :: int; sheep, wolf :: type.
:- constants
  cross(int, int) :: exogenousAction;
  here(type) :: inertialFluent(int);
  boat_here :: inertialFluent.
:- variables S, S1, HS, S_new :: int; W, W1, HW, W_new :: int; N, N1 :: int.

nonexecutable cross(S, W) if boat_here & here(sheep) = HS where HS < S.
nonexecutable cross(S, W) if boat_here & here(wolf) = HW where HW < W.
nonexecutable cross(S, W) if -boat_here & here(sheep) = HS where S + HS > NUM.
nonexecutable cross(S, W) if -boat_here & here(wolf) = HW where W + HW > NUM.
nonexecutable cross(S, W) where S == 0 & W == 0.
nonexecutable cross(S, W) where S + W > CAPACITY.

caused -boat_here after cross(S, W) & boat_here.
caused boat_here after cross(S, W) & -boat_here.
cross(S, W) causes here(sheep) = S_new if boat_here & here(sheep) = HS where S_new + S == HS.
cross(S, W) causes here(wolf) = W_new if boat_here & here(wolf) = HW where W_new + W == HW.
cross(S, W) causes here(sheep) = S_new if -boat_here & here(sheep) = HS where HS + S == S_new.
cross(S, W) causes here(wolf) = W_new if -boat_here & here(wolf) = HW where HW + W == W_new.

caused false if here(wolf) = N & here(sheep) = N1 where 0 < N1 & N1 < N.
caused false if here(wolf) = N & here(sheep) = N1 where N1 < NUM & N < N1.

:- query
  label :: 0;
  maxstep :: 0..{k};
  0: here(wolf) = NUM & here(sheep) = NUM & boat_here;
  maxstep: here(wolf) = {wolves} & here(sheep) = {sheep} & {'' if boat else '-'}boat_here.
"""
    return Instance(f"ferryman-{num}-{cap}-s{seed}", "ferryman", text, k, k)


# ------------------------------------------------------------------------------------- Hanoi


HANOI_LONGEST = 40      # moves: longer shortest plans take either planner well over 10 s


def _hanoi_moves(on: dict[int, str], disks: int, pegs: list[str]) -> list[tuple[int, str]]:
    below = set(on.values())
    top = [d for d in range(1, disks + 1) if str(d) not in below]
    out = []
    for d in top:
        for t in pegs + [str(x) for x in top]:
            if t == on[d] or t == str(d):
                continue
            if t in pegs and t in below:
                continue                          # a peg with a disk on it is not free
            if t not in pegs and d >= int(t):
                continue                          # only onto a bigger disk
            out.append((d, t))
    return out


def hanoi(seed: int) -> Instance:
    """3..6 disks on 3 or 4 pegs, from a random legal position; goal: a far state (its distance known)."""
    rng = random.Random(seed)
    disks = rng.randint(3, 6)
    npegs = rng.choice((3, 3, 4))
    pegs = [f"p{i}" for i in range(1, npegs + 1)]
    on: dict[int, str] = {}
    tops = {p: p for p in pegs}
    for d in range(disks, 0, -1):                 # biggest first: each disk on its peg's current top
        p = rng.choice(pegs)
        on[d], tops[p] = tops[p], str(d)
    start = dict(on)

    def successors(st: tuple[str, ...]) -> list[tuple[str, ...]]:
        here = dict(enumerate(st, 1))
        return [tuple(t if i == d else here[i] for i in range(1, disks + 1))
                for d, t in _hanoi_moves(here, disks, pegs)]
    dist = _distances(tuple(on[d] for d in range(1, disks + 1)), successors)
    goal = _far_state(dist, rng, cap=HANOI_LONGEST)
    on = dict(enumerate(goal, 1))
    k = dist[goal]

    def state(s: dict[int, str]) -> str:
        return " & ".join(f"on({d}) = {s[d]}" for d in range(1, disks + 1))
    text = f"""% random Towers of Hanoi: {disks} disks, {npegs} pegs, goal {k} moves away
% (bench/gen_instances.py, seed {seed}); the laws of the corpus's hanoi benchmarks
:- sorts loc >> peg; loc >> disk.
:- objects 1..{disks} :: disk; {', '.join(pegs)} :: peg.
:- constants
  on(disk) :: inertialFluent(loc);
  move(disk) :: exogenousAction(loc*).
:- variables D, D1 :: disk; L, L1 :: loc.

caused on(D) = L after move(D) = L.
nonexecutable move(D) = L & move(D1) = L1 where D \\= D1.
nonexecutable move(D) = L if on(D1) = L where D \\= D1.
nonexecutable move(D) = L if on(D1) = D where D \\= D1.
nonexecutable move(D) = D1 where D >= D1.

:- query
  label :: 0;
  maxstep :: 0..{k};
  0: {state(start)};
  maxstep: {state(on)}.
"""
    return Instance(f"hanoi-{disks}-{npegs}-s{seed}", "hanoi", text, k, k)


# ------------------------------------------------------------------------------------- car


def car(seed: int) -> Instance:
    """A car on a road of R metres: position, speed and clock; goal after a random walk of actions."""
    rng = random.Random(seed)
    road = rng.randrange(80, 241, 10)
    step = rng.randint(2, 4)
    top = step * rng.randint(4, 7)
    clock = rng.randrange(40, 101, 10)
    longest = rng.randint(5, 10)
    zone_from = rng.randrange(road // 4, road // 2, 5)
    zone_to = zone_from + rng.randrange(20, road // 3 + 1, 5)
    zone_speed = step * rng.randint(1, 2)
    k = rng.randint(4, 9)
    pos = spd = clk = 0

    def can_drive(d: int) -> bool:
        if pos + spd * d > road or clk + d > clock:
            return False
        return not (spd > zone_speed and pos + spd * d >= zone_from and pos <= zone_to)
    walked = 0
    while walked < k or pos == 0:
        choices = [("drive", d) for d in range(1, longest + 1) if can_drive(d) and spd > 0] * 2
        if spd + step <= top:
            choices.append(("up", 0))
        if spd >= step:
            choices.append(("down", 0))
        if not choices:
            break
        act, d = rng.choice(choices)
        if act == "drive":
            pos, clk = pos + spd * d, clk + d
        else:
            spd += step if act == "up" else -step
        walked += 1
    text = f"""% a random car on a {road} m road as a discretised hybrid automaton: speed steps of {step} m/s up to {top},
% a clock up to {clock} s, drives of 1..{longest} s, a school zone {zone_from}..{zone_to} m at {zone_speed} m/s at most;
% goal after a walk of {walked} actions (bench/gen_instances.py, seed {seed})
:- sorts position; speed; clock; duration.
:- objects 0..{road} :: position; 0..{top} :: speed; 0..{clock} :: clock; 1..{longest} :: duration.
:- variables P :: position; S :: speed; T :: clock; D, D1 :: duration.
:- constants
  pos :: inertialFluent(position);
  spd :: inertialFluent(speed);
  clk :: inertialFluent(clock);
  drive(duration) :: exogenousAction;
  speedUp, slowDown :: exogenousAction.

drive(D) causes pos = P + S * D if pos = P & spd = S where P + S * D =< {road}.
drive(D) causes clk = T + D if clk = T where T + D =< {clock}.
nonexecutable drive(D) if pos = P & spd = S where P + S * D > {road}.
nonexecutable drive(D) if clk = T where T + D > {clock}.
nonexecutable drive(D) & drive(D1) where D < D1.
speedUp causes spd = S + {step} if spd = S where S + {step} =< {top}.
slowDown causes spd = S - {step} if spd = S where S >= {step}.
nonexecutable speedUp if spd = S where S + {step} > {top}.
nonexecutable slowDown if spd = S where S < {step}.
nonexecutable speedUp & slowDown.
nonexecutable speedUp & drive(D).
nonexecutable slowDown & drive(D).
nonexecutable drive(D) if pos = P & spd = S where S > {zone_speed} & P + S * D >= {zone_from} & P =< {zone_to}.

:- query
  label :: 0;
  maxstep :: 0..{walked};
  0: pos = 0 & spd = 0 & clk = 0;
  maxstep: pos = {pos} & spd = {spd} & clk =< {clk}.
"""
    return Instance(f"car-{road}-s{seed}", "car", text, walked)


# ------------------------------------------------------------------------------------- drawing

FAMILIES: dict[str, Callable[[int], Instance]] = {
    "blocks": blocks_world, "spacecraft": spacecraft, "ferryman": ferryman, "hanoi": hanoi, "car": car,
}


def instance(name: str) -> Instance:
    """The instance a name stands for (``bw-23-s17``, ``hanoi-5-3-s4``...): made again from its seed."""
    prefix, _, seed = name.rpartition("-s")
    family = {"bw": "blocks"}.get(prefix.split("-")[0], prefix.split("-")[0])
    if family not in FAMILIES or not seed.isdigit():
        raise ValueError(f"not a generated instance name: {name!r}")
    made = FAMILIES[family](int(seed))
    if made.name != name:
        raise ValueError(f"{name!r}: seed {seed} makes {made.name!r}")
    return made


def draw(seed: int, count: int, families: list[str] | None = None) -> list[Instance]:
    """``count`` instances, the families in turn, each from a seed drawn from ``seed``."""
    families = families or list(FAMILIES)
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        raise ValueError(f"unknown famil{'y' if len(unknown) == 1 else 'ies'}: {', '.join(unknown)} "
                         f"(known: {', '.join(FAMILIES)})")
    rng = random.Random(seed)
    return [FAMILIES[families[i % len(families)]](rng.randrange(10 ** 6)) for i in range(count)]


def fresh_seed() -> int:
    return secrets.randbelow(10 ** 6)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="folder to write the .cp files into (made if missing)")
    ap.add_argument("--count", type=int, default=30)
    ap.add_argument("--seed", type=int, default=None, help="reproduce a draw (default: a fresh seed, printed)")
    ap.add_argument("--family", default=",".join(FAMILIES), help=f"comma-separated, of {', '.join(FAMILIES)}")
    args = ap.parse_args(argv)
    seed = fresh_seed() if args.seed is None else args.seed
    try:
        made = draw(seed, args.count, [f for f in args.family.split(",") if f])
    except ValueError as e:
        print(f"gen_instances: {e}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    print(f"seed {seed}: {len(made)} instances in {args.out}")
    for inst in made:
        print(f"  {inst.write(args.out)}  (a plan of length {inst.walk} exists)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
