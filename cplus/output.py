"""Print histories as CCALC does, and as versioned JSON (``cplus.plan/1``).

CCALC's layout (language reference E.2-E.5): an optional line of rigid atoms, then
``i:  atom  atom`` for each state and ``ACTIONS:  ...`` between states, blank lines between
all of them.  Attributes are printed inside their action (``move(b1,destination=table)``);
``:- show``/``:- hide`` choose what is displayed.  JSON holds the whole history whatever
is shown.
"""
from __future__ import annotations

from collections.abc import Iterable

from cplus import ir
from cplus.history import History, executed_actions, to_object
from cplus.history import json_value as _json_value
from cplus.program import Pattern, Program
from cplus.signature import GroundConst, NamedSort, RangeSort, Signature, render_value

__all__ = ["Display", "format_history", "format_result", "result_json", "unshown_changes", "PLAN_FORMAT"]

PLAN_FORMAT = "cplus.plan/1"


class Display:
    """Which atoms are displayed, and in which order (E.4, E.5)."""

    def __init__(self, program: Program) -> None:
        self.program = program
        self.sig: Signature = program.signature
        self._order: dict[int, tuple] = {}

    # -- show / hide ---------------------------------------------------------------
    @property
    def specs(self) -> list:
        """The show specifications in force: the ``:- show`` items, else CCALC's default
        ``positive`` (nothing at all after ``:- hide all`` without a ``:- show``)."""
        prog = self.program
        if prog.show_given:
            return prog.show
        return [] if prog.hide_all else ["positive"]

    def _matches(self, p: Pattern, gc: GroundConst, value: object, step: int | None = None) -> bool:
        if p.step is not None and p.step != step:
            return False
        if p.decl is None:
            if gc.decl.name != p.name:
                return False
        else:
            if p.decl is not gc.decl:
                return False
            for a, v in zip(p.args, gc.args):
                if isinstance(a, ir.Var):
                    if not self._in_sort(a, v):
                        return False
                elif a != v:
                    return False
        if p.negated:
            return value is False
        if p.value is None:
            return not gc.boolean or value is True
        if isinstance(p.value, ir.Var):
            return self._in_sort(p.value, to_object(gc, value))
        return p.value == to_object(gc, value)

    def _in_sort(self, var: ir.Var, value: object) -> bool:
        try:
            return self.sig.contains(var.sort, value)
        except TypeError:
            return True

    def shown(self, gc: GroundConst, value: object, step: int | None = None) -> bool:
        """Whether the atom ``gc=value`` (at ``step``; None for a rigid constant) is displayed (a
        value as a :class:`History` holds it: for a Boolean constant, ``False`` is the literal
        ``-gc``), as CCALC 2's ``in_show_list`` decides with the specifications in force
        (:attr:`specs`), then no ``:- hide`` pattern matching it.

        * an abnormality (a constant named by ``unless``): only with ``ab`` (when true), ``all``,
          or a pattern; except that an abnormality fluent with arguments (``unless ab1(M,M1)``
          in a static law) is shown as the other fluents are, because CCALC prints it (its
          ``show_fluent`` hides an atom equal to the ``unless`` term as written, variables and
          all, so only one without arguments; the recorded sessions of multiple-monkey-test
          print ``ab1(alice,david)``);
        * actions: a true Boolean action, or any value of a non-Boolean one, when the specs
          hold ``positive`` or ``all`` or a pattern matching it; never a false one;
        * fluents and rigid constants: ``positive`` shows true Boolean atoms and the values of
          the others except ``none``; ``negative`` the false Boolean atoms (``-p``) and ``c=none``;
          ``all`` both; a pattern what it matches;
        * ``none`` shows nothing; constants internal to the encoding are never shown.
        """
        d = gc.decl
        if d.hidden:
            return False
        negative = gc.boolean and value is not True
        specs = self.specs
        if d.abnormal and (d.is_action or not d.argsorts):
            ok = any(s == "all" or (s == "ab" and not negative) or (not isinstance(s, str) and self._matches(s, gc, value, step))
                     for s in specs)
        elif d.is_action:
            ok = not negative and any(s in ("all", "positive") or (not isinstance(s, str) and self._matches(s, gc, value, step))
                                      for s in specs)
        else:
            none = value == "none"
            ok = any(s == "all" or (s == "positive" and not negative and not none)
                     or (s == "negative" and (negative or none))
                     or (not isinstance(s, str) and self._matches(s, gc, value, step)) for s in specs)
        return ok and not any(self._matches(p, gc, value, step) for p in self.program.hide)

    @property
    def hides_something(self) -> bool:
        """The program has ``:- show`` or ``:- hide`` statements (without them CCALC's default,
        ``positive``, shows every change of a step)."""
        prog = self.program
        return bool(prog.show_given or prog.hide or prog.hide_all)

    # -- order ---------------------------------------------------------------------
    def key(self, gc: GroundConst) -> tuple:
        k = self._order.get(gc.id)
        if k is None:
            d = gc.decl
            if d.is_action:
                family = 2
            elif d.kind == "sdFluent":
                family = 1
            else:
                family = 0
            dom = d.domain
            if isinstance(dom, NamedSort):
                sort_key: tuple = (0, str(dom))
            elif isinstance(dom, RangeSort):
                sort_key = (1, dom.lo, dom.hi)
            else:
                sort_key = (2,)
            sub = 0 if d.kind in ("simpleFluent", "sdFluent", "rigid") else 1
            if family == 2:
                sort_key, sub = (0,), 0
            order = self.sig.object_order
            args = tuple((0, a, 0) if isinstance(a, int) else (1, 0, order.get(a, 1 << 30)) for a in gc.args)
            k = self._order[gc.id] = (family, sort_key, sub, d.order, args)
        return k

    # -- rendering -----------------------------------------------------------------
    def atom_text(self, gc: GroundConst, value: object) -> str:
        if gc.boolean:
            return gc.text if value is True else "-" + gc.text
        return f"{gc.text}={render_value(value)}"  # type: ignore[arg-type]

    def state_atoms(self, table: dict[GroundConst, object], step: int | None = None) -> list[str]:
        """The displayed atoms of a state: the positive ones, then the negative ones (as CCALC
        prints them, in two passes)."""
        gcs = sorted((gc for gc, v in table.items() if self.shown(gc, v, step)), key=self.key)
        pos = [gc for gc in gcs if not (gc.boolean and table[gc] is not True)]
        neg = [gc for gc in gcs if gc.boolean and table[gc] is not True]
        return [self.atom_text(gc, table[gc]) for gc in pos + neg]

    def action_atoms(self, table: dict[GroundConst, object], step: int | None = None) -> list[str]:
        out = []
        negative = []
        for gc in sorted(table, key=self.key):
            d = gc.decl
            if d.kind == "attribute" or not self.shown(gc, table[gc], step):
                continue
            attrs = self._attributes(gc, table)
            if gc.boolean:
                if table[gc] is not True:
                    negative.append("-" + gc.text)
                    continue
                if attrs:
                    inner = ",".join([render_value(a) for a in gc.args] + attrs)
                    out.append(f"{d.name}({inner})")
                else:
                    out.append(gc.text)
            else:
                out.append(self.atom_text(gc, table[gc]))
        return out + negative

    def _attributes(self, gc: GroundConst, table: dict) -> list[str]:
        items = []
        for ad in gc.decl.attributes:
            for ag, v in table.items():
                if ag.decl is not ad or ag.args[:gc.decl.arity] != gc.args:
                    continue
                if v == "none" or any(self._matches(p, ag, v) for p in self.program.hide):
                    continue     # CCALC prints every attribute of a displayed action
                rest = ag.args[gc.decl.arity:]
                name = ad.name + (f"({','.join(render_value(a) for a in rest)})" if rest else "")
                shown_v = render_value(to_object(ag, v))  # type: ignore[arg-type]
                if isinstance(v, int) and v < 0:
                    shown_v = " " + shown_v
                items.append(((ad.order, self.key(ag)), f"{name}={shown_v}"))
        return [t for _, t in sorted(items)]


UNSHOWN_SHOWN = 8
"""The most atoms an unshown-change note names (then ``...``)."""


def format_history(display: Display, hist: History) -> str:
    """CCALC's text of one history.  Where the domain's ``:- show``/``:- hide`` leave out
    all that a step changes, so that two states print alike with no ``ACTIONS`` line
    between them, a comment line says what changed (CCALC prints nothing there, and the
    step looks like a mistake), or that it changes nothing; a domain that shows and hides
    nothing prints as CCALC's."""
    lines: list[str] = []
    rigid = display.state_atoms(hist.rigid)
    if rigid:
        lines.append("  ".join(rigid))
    states = [display.state_atoms(state, t) for t, state in enumerate(hist.states)]
    for t, state in enumerate(hist.states):
        lines.append(f"{t}:  " + "  ".join(states[t]))
        if t < len(hist.actions):
            acts = display.action_atoms(hist.actions[t], t)
            if acts:
                lines.append("ACTIONS:  " + "  ".join(acts))
            elif states[t] == states[t + 1] and display.hides_something:
                unshown = unshown_changes(display, state, hist.actions[t], hist.states[t + 1], t)
                named = unshown[:UNSHOWN_SHOWN] + (["..."] if len(unshown) > UNSHOWN_SHOWN else [])
                lines.append(f"% step {t} -> {t + 1} changes only what the show statements leave out: "
                             + "  ".join(named) if unshown else f"% step {t} -> {t + 1} changes nothing")
    return "\n" + "\n\n".join(line.rstrip() for line in lines) + "\n\n\n"


def unshown_changes(display: Display, before: dict[GroundConst, object], actions: dict[GroundConst, object],
                    after: dict[GroundConst, object], step: int | None = None) -> list[str]:
    """What step ``step`` -> ``step + 1`` does that the display leaves out: the actions executed
    and the fluents whose value changed, as atoms (``canCarry``, ``-trayUp``, ``loc(b1)=table``),
    in the display's order."""
    done = [gc for gc in executed_actions(actions) if not display.shown(gc, actions[gc], step)]
    changed = [gc for gc, v in after.items()
               if before.get(gc) != v and not display.shown(gc, v, None if step is None else step + 1)]
    return [display.atom_text(gc, actions[gc]) for gc in sorted(done, key=display.key)] + \
        [display.atom_text(gc, after[gc]) for gc in sorted(changed, key=display.key)]


def format_result(display: Display, failed: Iterable[int], histories: list[History], numbered: bool | None = None,
                  heading: str = "Solution") -> str:
    """CCALC's text of a query's answer: ``No solution with maxstep m.`` for each length tried
    in vain, then the histories, each headed ``Solution k:`` (``heading``: ``State`` for the
    shell's ``sat.``) when ``numbered``; None: when there are several, as CCALC's
    ``show_models`` numbers only a list of two or more."""
    if numbered is None:
        numbered = len(histories) > 1
    parts = [f"\nNo solution with maxstep {m}.\n\n" for m in failed]
    for k, h in enumerate(histories, start=1):
        if numbered:
            parts.append(f"{heading} {k}:\n")
        parts.append(format_history(display, h))
    return "".join(parts)


def history_json(hist: History) -> dict:
    def table(t: dict) -> dict:
        return {gc.text: _json_value(gc, v) for gc, v in sorted(t.items(), key=lambda kv: kv[0].id)}
    steps = []
    for a in hist.actions:
        done = []
        for gc in sorted(executed_actions(a), key=lambda g: g.id):
            entry: dict = {"action": gc.text}
            if not gc.boolean:
                entry["value"] = _json_value(gc, a[gc])
            attrs = {ag.text: _json_value(ag, v) for ag, v in a.items()
                     if ag.decl.parent is gc.decl and ag.args[:gc.decl.arity] == gc.args and v != "none"}
            if attrs:
                entry["attributes"] = attrs
            done.append(entry)
        steps.append(done)
    return {"maxstep": hist.maxstep, "rigid": table(hist.rigid),
            "states": [table(s) for s in hist.states], "actions": steps}


def result_json(program_path: str, result, query) -> dict:
    """The ``cplus.plan/1`` document of one query's result."""
    return {
        "format": PLAN_FORMAT,
        "file": program_path,
        "query": {"label": result.label, "kind": "nmquery" if query.nm else "query", "min_maxstep": query.lo,
                  "max_maxstep": query.hi},
        "status": result.status.value,
        "maxstep": result.maxstep,
        "no_solution_with_maxstep": list(result.failed),
        "histories": [history_json(h) for h in result.histories],
        "stats": [{"maxstep": s.maxstep, "variables": s.variables, "clauses": s.clauses,
                   "encode_s": round(s.encode_s, 6), "solve_s": round(s.solve_s, 6),
                   "satisfiable": s.satisfiable} for s in result.stats],
    }
