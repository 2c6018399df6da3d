"""A small LALR(1) runtime over the tables lark builds for ``grammar/cplus.lark``.

Why: importing lark and loading its cached parser costs about 35 ms of processor time, half
of what a ``cplus plan`` of a small domain spends; a plain ``cplus plan`` needs only the
tables.  So lark builds them (once: they are kept in the user's cache directory as plain
data, see :func:`cplus.parser.tables`), and this module parses with them, reproducing
exactly what lark's ``parser="lalr"`` front end with its contextual lexer,
``propagate_positions=True`` and ``maybe_placeholders=False`` returns: the same tree
shapes (``?rule`` inlining, ``_rule`` splicing, anonymous tokens filtered, aliases) and the
same positions (``meta.start_pos``/``end_pos``, with lark's container rules).

Only well-formed statements are parsed here: on any error :class:`NoParse` is raised and the
caller asks lark itself, whose exceptions carry what the error messages need.

The tables (see :func:`tables_of`): ``states`` maps a parser state to ``{symbol: (0, state)}``
for a shift or ``{symbol: (1, rule)}`` for a reduction; ``rules`` lists ``(origin, size,
name, expand1, include)`` where ``include`` is ``None`` (keep every child) or the
``(index, splice)`` pairs of the children kept; ``terminals`` lists every terminal's
``(name, pattern)`` in the order lark tries them (``flags`` for all); ``lexers`` lists, per
distinct lexer, ``(names, ignore, unless)``: the terminals it reads (in that order), those it
skips, and for a terminal whose text may be a keyword the keywords' texts and terminals;
``lexer_of`` maps a parser state to its lexer.
"""
from __future__ import annotations

import re
from collections.abc import Callable

__all__ = ["NoParse", "Parser", "Token", "Tree", "Meta", "tables_of", "from_lark"]

FORMAT = 2
"""Version of the tables' layout: kept with them, a cache of another layout is rebuilt."""


class NoParse(Exception):
    """The text is not a statement of the grammar (lark says why)."""


class Token(str):
    """A terminal: its text, its terminal's name and its offsets in the parsed text."""

    type: str
    start_pos: int
    end_pos: int

    def __new__(cls, type_: str, value: str, start_pos: int, end_pos: int) -> Token:
        self = super().__new__(cls, value)
        self.type = type_
        self.start_pos = start_pos
        self.end_pos = end_pos
        return self


class Meta:
    """Where a node is: ``start_pos``/``end_pos`` of its own first and last positioned
    children, ``cstart``/``cend`` those of the outermost rule it was inlined from (lark's
    ``container_*``, which a parent's position is taken from)."""

    __slots__ = ("start_pos", "end_pos", "cstart", "cend", "empty")

    def __init__(self) -> None:
        self.start_pos: int | None = None
        self.end_pos: int | None = None
        self.cstart = 0
        self.cend = 0
        self.empty = True


class Tree:
    """A rule's node: its name (``data``), its children (trees and tokens) and :class:`Meta`."""

    __slots__ = ("data", "children", "meta")

    def __init__(self, data: str, children: list, meta: Meta | None = None) -> None:
        self.data = data
        self.children = children
        self.meta = meta if meta is not None else Meta()

    def __repr__(self) -> str:
        return f"Tree({self.data!r}, {self.children!r})"


class Parser:
    """Parses statements with one set of tables.

    lark compiles one alternation of the terminals a parser state accepts per distinct set
    (a third of a small run's processor time went to compiling them); here one alternation of
    every terminal, in lark's order, is tried first: when the terminal it finds is one the
    state accepts, it is the one lark's alternation would find (the first in the same order
    that matches); otherwise the state's terminals after it are tried one by one.
    """

    def __init__(self, tables: dict) -> None:
        self._states: dict = tables["states"]
        self._start: int = tables["start"]
        self._end: int = tables["end"]
        self._rules: list = tables["rules"]
        self._terminals: list = tables["terminals"]
        self._flags: int = tables["flags"]
        self._rank = {name: i for i, (name, _) in enumerate(self._terminals)}
        self._lexer_specs: list = tables["lexers"]
        self._lexer_of: dict = tables["lexer_of"]
        self._lexers: dict[int, tuple] = {}
        self._single: dict[str, Callable] = {}
        self._root_match: Callable | None = None

    def _lexer(self, index: int) -> tuple:
        lexer = self._lexers.get(index)
        if lexer is None:
            names, ignore, unless = self._lexer_specs[index]
            lexer = (frozenset(names), [(self._rank[n], n) for n in names], frozenset(ignore), unless)
            self._lexers[index] = lexer
        return lexer

    def _match(self, text: str, pos: int, lexer: tuple) -> tuple[str, str] | None:
        """The terminal and text that the state's lexer reads at ``pos``, as lark's would."""
        if self._root_match is None:
            self._root_match = re.compile("|".join(f"(?P<{n}>{p})" for n, p in self._terminals),
                                          self._flags).match
        m = self._root_match(text, pos)
        if m is None:
            return None
        found = m.lastgroup
        assert found is not None
        allowed, ordered, _, _ = lexer
        if found in allowed:
            return found, m.group(0)
        after = self._rank[found]
        for rank, name in ordered:
            if rank > after:
                match = self._single.get(name)
                if match is None:
                    match = self._single[name] = re.compile(self._terminals[rank][1], self._flags).match
                m = match(text, pos)
                if m:
                    return name, m.group(0)
        return None

    def _next_token(self, text: str, pos: int, state: int) -> Token | None:
        """The next token the lexer of ``state`` reads at ``pos`` (None at the end)."""
        lexer = self._lexer(self._lexer_of[state])
        ignore, unless = lexer[2], lexer[3]
        end = len(text)
        while pos < end:
            found = self._match(text, pos, lexer)
            if found is None:
                raise NoParse(pos)
            type_, value = found
            if type_ in ignore:
                pos += len(value)
                continue
            if type_ in unless:
                type_ = unless[type_].get(value, type_)
            return Token(type_, value, pos, pos + len(value))
        return None

    def parse(self, text: str) -> Tree | Token:
        states = self._states
        rules = self._rules
        stack = [self._start]
        values: list = []
        pos = 0
        while True:
            token = self._next_token(text, pos, stack[-1])
            is_end = token is None
            if token is None:
                token = Token("$END", "", pos, pos)
            else:
                pos = token.end_pos
            while True:
                action = states[stack[-1]].get(token.type)
                if action is None:
                    raise NoParse(token.start_pos)
                if action[0] == 0:          # shift
                    if is_end:
                        raise NoParse(pos)
                    stack.append(action[1])
                    values.append(token)
                    break
                origin, size, name, expand1, include = rules[action[1]]
                if size:
                    children = values[-size:]
                    del stack[-size:]
                    del values[-size:]
                else:
                    children = []
                value = _node(children, name, expand1, include)
                stack.append(states[stack[-1]][origin][1])
                values.append(value)
                if is_end and stack[-1] == self._end:
                    return values[-1]


def _node(children: list, name: str, expand1: bool, include) -> Tree | Token:
    """lark's tree builder for one reduction: filter and splice, inline a single child,
    then place the result (propagate_positions)."""
    if include is None:
        kept = list(children)
    else:
        kept = []
        for i, splice in include:
            if splice:
                kept += children[i].children
            else:
                kept.append(children[i])
    res = kept[0] if expand1 and len(kept) == 1 else Tree(name, kept)
    if isinstance(res, Tree):
        meta = res.meta
        start = _edge(children, "cstart", "start_pos")
        if start is None:
            return res
        if meta.start_pos is None:
            meta.start_pos = start
            meta.empty = False
        meta.cstart = start
        end = _edge(reversed(children), "cend", "end_pos")
        assert end is not None       # the child that gave the start has an end
        if meta.end_pos is None:
            meta.end_pos = end
            meta.empty = False
        meta.cend = end
    return res


def _edge(children, of_tree: str, of_token: str) -> int | None:
    """The position of the first child (in the order given) that has one: a token's, or a
    non-empty subtree's ``of_tree`` position, as lark's position propagation takes it."""
    for c in children:
        if isinstance(c, Tree):
            if not c.meta.empty:
                return getattr(c.meta, of_tree)
        else:
            return getattr(c, of_token)
    return None


# --------------------------------------------------------------------------- from lark


def tables_of(lark_parser) -> dict:
    """The plain-data tables of a lark LALR parser built with the options above (see the
    module's docstring); plain so that they load without importing lark."""
    from lark.lexer import UnlessCallback

    frontend = lark_parser.parser
    table = frontend.parser.parser.parse_table
    rules: list = []
    index: dict = {}
    states: dict = {}
    for state, actions in table.states.items():
        row = {}
        for sym, (action, arg) in actions.items():
            if action.name == "Shift":
                row[str(sym)] = (0, int(arg))
            else:
                if arg not in index:
                    index[arg] = len(rules)
                    rules.append(_rule(arg))
                row[str(sym)] = (1, index[arg])
        states[int(state)] = row
    lexers: list = []
    lexer_index: dict = {}
    lexer_of: dict = {}
    for state, lexer in frontend.lexer.lexers.items():
        if id(lexer) not in lexer_index:
            scanner = lexer.scanner        # built on first use; it sets lexer.callback
            unless = {}
            for type_, cb in lexer.callback.items():
                if not isinstance(cb, UnlessCallback) or any(t.pattern.type != "str" or t.pattern.flags
                                                             for t in cb.scanner.terminals):
                    raise ValueError(f"lexer callback {cb!r} on {type_} is not reproduced")
                unless[str(type_)] = {str(t.pattern.value): str(t.name) for t in cb.scanner.terminals}
            lexer_index[id(lexer)] = len(lexers)
            lexers.append(([str(t.name) for t in scanner.terminals], sorted(map(str, lexer.ignore_types)), unless))
        lexer_of[int(state)] = lexer_index[id(lexer)]
    root = frontend.lexer.root_lexer
    terminals = [(str(t.name), str(t.pattern.to_regexp())) for t in root.terminals]
    rank = {name: i for i, (name, _) in enumerate(terminals)}
    for names, _, _ in lexers:
        if [rank[n] for n in names] != sorted(rank[n] for n in names):
            raise ValueError("a lexer's terminals are not in the root lexer's order")
    (start,) = table.start_states.values()
    (end,) = table.end_states.values()
    return {"format": FORMAT, "states": states, "start": int(start), "end": int(end), "rules": rules,
            "terminals": terminals, "flags": int(frontend.lexer_conf.g_regex_flags), "lexers": lexers,
            "lexer_of": lexer_of}


def _rule(rule) -> tuple:
    """``(origin, size, name, expand1, include)`` as lark's ParseTreeBuilder shapes it."""
    options = rule.options
    if options.keep_all_tokens or options.template_source:
        raise ValueError(f"rule {rule} uses a lark option not reproduced here")
    name = rule.alias or rule.origin.name
    expansion = rule.expansion
    include = [(i, not sym.is_term and sym.name.startswith("_")) for i, sym in enumerate(expansion)
               if not (sym.is_term and sym.filter_out)]
    keep_all = len(include) == len(expansion) and not any(splice for _, splice in include)
    return (str(rule.origin.name), len(expansion), str(name), bool(options.expand1 and not rule.alias),
            None if keep_all else include)


def from_lark(node) -> Tree | Token:
    """A lark tree as this module's (for a statement only lark could parse)."""
    from lark import Tree as LarkTree

    if not isinstance(node, LarkTree):
        return Token(node.type, str(node), node.start_pos, node.end_pos)
    meta = Meta()
    if not node.meta.empty:
        meta.start_pos, meta.end_pos, meta.empty = node.meta.start_pos, node.meta.end_pos, False
    return Tree(str(node.data), [from_lark(c) for c in node.children], meta)
