"""``--animate FILE`` and its knobs, shared by ``cplus plan``, ``cplus execute``, ``cplus run`` and
``cplus replay``: the options, the check made before any work starts, and the progress lines.

Nothing here imports matplotlib until an animation is asked for (``cplus plan`` stays light).
"""
from __future__ import annotations

import argparse
from typing import TextIO

__all__ = ["DEFAULT_DPI", "DEFAULT_FRAMES", "FrameProgress", "add_animation_options", "animation_check"]

#: The command line's defaults: those of :func:`trajectory.animate.animate_run` (a test holds
#: them equal), written here so that building a parser does not import matplotlib.
DEFAULT_FRAMES = 150
DEFAULT_DPI = 100


def add_animation_options(p: argparse.ArgumentParser | argparse._ArgumentGroup, what: str = "executed over planned",
                          *, default_file: str | None = None) -> None:
    """``--animate FILE`` and its knobs (``cplus execute``, ``cplus run``, ``cplus plan``, ``cplus replay``).
    With ``default_file``, ``--animate`` alone stores True: the command puts its default file there."""
    extra = {"nargs": "?", "const": True, "action": _OptionalFile} if default_file else {}
    also = f"; --animate alone: {default_file}" if default_file else ""
    if not default_file:
        extra = {"type": _file_name}
    p.add_argument("--animate", metavar="FILE", **extra,  # type: ignore[arg-type]
                   help=f"write an animation of the arms, the payload and the obstacles, {what} (.gif; .mp4 "
                        f"needs ffmpeg{also})")
    p.add_argument("--frames", type=_frames, default=DEFAULT_FRAMES, metavar="N",
                   help=f"with --animate: at most N frames, sampled evenly (default {DEFAULT_FRAMES})")
    p.add_argument("--dpi", type=_dpi, default=DEFAULT_DPI, metavar="N",
                   help=f"with --animate: dots per inch of the 8 in wide frames (default {DEFAULT_DPI})")


class _OptionalFile(argparse.Action):
    """``--animate [FILE]`` before the domain file takes the domain as its FILE (argparse cannot
    tell them apart): say so, instead of argparse's "the following arguments are required"."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        if values == "":
            parser.error(f"argument {option_string}: an empty file name")
        if isinstance(values, str) and values.lower().endswith(".cp"):
            parser.error(f"{option_string} took {values!r} as its FILE: put {option_string} after the domain "
                         f"file, or write {option_string}=FILE")
        setattr(namespace, self.dest, values)


def _file_name(text: str) -> str:
    if not text:
        raise argparse.ArgumentTypeError("an empty file name")
    return text


def _frames(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number of frames, got {text!r}") from None
    if not 1 <= n <= 10000:
        raise argparse.ArgumentTypeError(f"must be from 1 to 10000 frames, got {n}")
    return n


def _dpi(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected whole dots per inch, got {text!r}") from None
    if not 10 <= n <= 600:
        raise argparse.ArgumentTypeError(f"must be from 10 to 600 dpi, got {n}")
    return n


def animation_check(path: str | None, option: str, prog: str) -> str | None:
    """One line when ``path`` cannot take an animation (its name, ffmpeg), or None; whether it
    can be written is the command's check, with its other paths (:mod:`cplus.cli.paths`)."""
    if not path:
        return None
    from trajectory.animate import animation_problem
    problem = animation_problem(path)
    return None if problem is None else f"{prog}: error: {option} {path}: {problem}"


class FrameProgress:
    """Progress of a long animation on stderr: a line at every quarter."""

    def __init__(self, prog: str, path: str, out: TextIO, quiet: bool = False) -> None:
        self.prog, self.path, self.out, self.quiet = prog, path, out, quiet
        self.shown = -1

    def __call__(self, done: int, total: int) -> None:
        quarter = 4 * done // max(total, 1)
        if self.quiet or total < 20 or quarter == self.shown or quarter == 0:
            return
        self.shown = quarter
        print(f"{self.prog}: animating {self.path}: frame {done}/{total}", file=self.out, flush=True)


