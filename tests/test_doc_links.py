"""Every relative link and ``#anchor`` of README.md and docs/*.md resolves (issue 31).

A link ``[text](target)`` (or an image, or ``<a href>``/``<img src>``) whose target is not a
URL must name a file or folder of the repository, and its ``#anchor``, in a Markdown file,
one of that file's headings as GitHub makes anchors of them: the heading's text without its
markup, lower-cased, every character that is not a letter, a digit, ``_``, ``-`` or a space
dropped, spaces turned into ``-``; a second heading with the same anchor gets ``-1``, a third
``-2``. ``<a id>``/``<a name>`` anchors count too. Code (fenced blocks and code spans) is not
looked into.
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

FENCE = re.compile(r"^\s*(```|~~~)")
CODE_SPAN = re.compile(r"(`+)(.+?)\1")
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*<?([^)\s>]*)>?(?:\s+\"[^\"]*\")?\s*\)")
HTML_LINK = re.compile(r"<(?:a|img)\s[^>]*?(?:href|src)=\"([^\"]+)\"", re.I)
HTML_ANCHOR = re.compile(r"<a\s[^>]*?(?:id|name)=\"([^\"]+)\"", re.I)
HEADING = re.compile(r"^ {0,3}(#{1,6})\s+(.*?)\s*#*\s*$")


def prose(text: str) -> list[tuple[int, str]]:
    """(line number, line) outside fenced code blocks."""
    lines, inside = [], False
    for n, line in enumerate(text.split("\n"), 1):
        if FENCE.match(line):
            inside = not inside
            continue
        if not inside:
            lines.append((n, line))
    return lines


def github_anchor(heading: str) -> str:
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)       # a link: its text
    text = re.sub(r"<[^>]+>", "", text)                                # HTML tags
    text = text.replace("`", "")
    text = re.sub(r"(\*\*|__|\*|(?<!\w)_|_(?!\w))", "", text)          # emphasis markers
    text = text.strip().lower()
    text = "".join(c for c in text if c.isalnum() or c in "_- ")
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    found: set[str] = set()
    seen: dict[str, int] = {}
    for _, line in prose(page.read_text(encoding="utf-8")):
        m = HEADING.match(line)
        if m:
            base = github_anchor(m.group(2))
            n = seen.get(base, 0)
            found.add(base if n == 0 else f"{base}-{n}")
            seen[base] = n + 1
        found.update(a.lower() for a in HTML_ANCHOR.findall(line))
    return found


def links(page: Path) -> list[tuple[int, str]]:
    out = []
    for n, line in prose(page.read_text(encoding="utf-8")):
        bare = CODE_SPAN.sub("", line)
        out += [(n, t) for t in LINK.findall(bare) + HTML_LINK.findall(bare)]
    return out


def relative(target: str) -> bool:
    return bool(target) and not re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I)


CASES = [(page, n, target) for page in PAGES for n, target in links(page) if relative(target)]


@pytest.mark.parametrize("page, line, target", CASES,
                         ids=[f"{p.relative_to(ROOT)}:{n}:{t}" for p, n, t in CASES])
def test_the_link_resolves(page: Path, line: int, target: str) -> None:
    where = f"{page.relative_to(ROOT)}:{line}: {target}"
    path, _, anchor = target.partition("#")
    file = (page.parent / path).resolve() if path else page
    assert file.exists(), f"{where}: no such file"
    assert file == ROOT or ROOT in file.parents, f"{where}: outside the repository"
    if anchor and file.suffix == ".md":
        assert anchor in anchors(file), f"{where}: no heading of {file.name} has the anchor #{anchor}"


def test_links_are_found() -> None:
    """The extraction itself: the README links docs/, docs/ link each other and anchors."""
    assert any(p.name == "README.md" and t.startswith("docs/") for p, _, t in CASES)
    assert sum("#" in t for _, _, t in CASES) >= 20


@pytest.mark.parametrize("heading, anchor", [
    ("`cplus ground FILE --maxstep N --dimacs OUT [--query LABEL]`",
     "cplus-ground-file---maxstep-n---dimacs-out---query-label"),
    ("The world: `cplus.world/1`", "the-world-cplusworld1"),
    ("The delivery robot's program: `cplus_legolog.nxc`", "the-delivery-robots-program-cplus_legolognxc"),
    ("A robot task end to end: `cplus run`", "a-robot-task-end-to-end-cplus-run"),
    ("7. Queries", "7-queries"),
    ("Proofs that no plan exists: `maxstep :: any` and `invariant:`",
     "proofs-that-no-plan-exists-maxstep--any-and-invariant"),
    ("**Bold** and [a link](x.md)", "bold-and-a-link"),
])
def test_anchors_are_made_as_github_makes_them(heading: str, anchor: str) -> None:
    assert github_anchor(heading) == anchor


def test_a_repeated_heading_gets_a_number(tmp_path: Path) -> None:
    page = tmp_path / "p.md"
    page.write_text("# Errors\n\n```\n# not a heading\n```\n\n## Errors\n\n### Errors\n")
    assert anchors(page) == {"errors", "errors-1", "errors-2"}
