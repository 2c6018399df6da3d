"""Every command's input and output paths, declared in one place and checked before any work.

A command lists what it reads (:class:`Input`: the domain, the scene, a job file, ...) and
what it writes (:class:`Output`: the option and its path) and calls :func:`check_paths`
before it loads, plans or moves anything.  The rules, one line each when broken, naming the
option (``cplus plan: error: --trajectory scene.toml: it is the scene this command reads``):

* an output is never an input: compared with :func:`os.path.samefile` (links and hard links
  included) against every input that is a regular file;
* no two outputs are one regular file (two may go to ``/dev/null``);
* an output that exists is a regular file (replaced atomically, its folder must take the
  temporary file), or something written through (a device, a FIFO, a link: never replaced;
  :mod:`cplus.files` writes by the same rule); a directory, a socket or a broken link is
  refused;
* a missing output's folder must exist: nothing is created unless the option says so
  (``cplus run --out DIR`` creates DIR, not its parents), and creating a file there is tried
  (and undone), so ``/proc`` or a read-only file system is refused before the work, not after.
"""
from __future__ import annotations

import os
import stat
from collections.abc import Iterable

from cplus.cli.common import CliError
from cplus.record import Record

__all__ = ["Input", "Output", "check_paths", "output_problem"]


class Input(Record):
    """A file the command reads: ``what`` names it in a message (``the scene``)."""

    _fields = ("path", "what")
    __slots__ = _fields

    def __init__(self, path: str | None, what: str) -> None:
        self.path = path
        self.what = what


class Output(Record):
    """A file (``folder``: a folder the option asks the command to create) the command writes,
    given by ``option``; ``stdout``: ``-`` is standard output.  ``inside``: a file the command
    writes inside a folder output (checked once that folder exists)."""

    _fields = ("option", "path", "stdout", "folder", "inside")
    __slots__ = _fields

    def __init__(self, option: str, path: str | None, stdout: bool = False, folder: bool = False,
                 inside: str | None = None) -> None:
        self.option = option
        self.path = path
        self.stdout = stdout
        self.folder = folder
        self.inside = inside


def check_paths(prog: str, inputs: Iterable[Input], outputs: Iterable[Output]) -> None:
    """Refuse the first output that breaks a rule of the module (see its docstring).

    Raises:
        CliError: one line, ``PROG: error: OPTION PATH: why``.
    """
    sources = [i for i in inputs if i.path and i.path != "-" and os.path.isfile(i.path)]
    seen: list[tuple[Output, str]] = []
    new_folders: set[str] = set()
    for out in outputs:
        if out.path is None:
            continue
        if out.path == "-" and out.stdout:
            continue
        if out.path == "":
            raise CliError(f"{prog}: error: {out.option}: an empty file name")
        if out.inside is not None and os.path.abspath(out.inside) in new_folders:
            continue            # inside a folder the command creates: nothing there yet
        why = _folder_problem(out.path, new_folders) if out.folder else _file_problem(out.path)
        for source in sources:
            if why is None and _same(out.path, source.path):        # type: ignore[arg-type]
                why = f"it is {source.what} this command reads"
        if why is not None:
            raise CliError(f"{prog}: error: {out.option} {out.path}: {why}")
        for other, path in seen:
            if _same(out.path, path) and _replaced(out.path):     # a device may take two outputs
                raise CliError(f"{prog}: error: {other.option} and {out.option} are the same file {out.path}")
        seen.append((out, out.path))


def _replaced(path: str) -> bool:
    """A path whose content an output replaces (a regular file, or nothing yet)."""
    try:
        return stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return True


def _same(a: str, b: str) -> bool:
    """One file: the same inode when both exist, else the same absolute path."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def _file_problem(path: str) -> str | None:
    try:
        st = os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return _new_file_problem(path)
    except OSError as exc:
        return exc.strerror
    if stat.S_ISLNK(st.st_mode):
        try:
            st = os.stat(path)
        except OSError:
            return f"it is a link to {os.readlink(path)}, which cannot be opened"
        if stat.S_ISDIR(st.st_mode):
            return "it is a directory"
        return None if os.access(path, os.W_OK) else "permission denied"
    if stat.S_ISDIR(st.st_mode):
        return "it is a directory"
    if stat.S_ISSOCK(st.st_mode):
        return "it is a socket"
    if not os.access(path, os.W_OK):
        return "permission denied"
    if stat.S_ISREG(st.st_mode):            # replaced: the temporary file goes beside it
        return _cannot_create_in(os.path.dirname(os.path.abspath(path)))
    return None                             # a device or a FIFO: written through


def _new_file_problem(path: str) -> str | None:
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.exists(parent):
        return f"no such directory {_nearest_missing(parent)} (it is not created)"
    if not os.path.isdir(parent):
        return f"{_nearest_file(parent)} is not a directory"
    return _cannot_create_in(parent)


def _folder_problem(path: str, new_folders: set[str]) -> str | None:
    """A folder the command is asked to create (or to fill, if it exists)."""
    p = os.path.abspath(path)
    if os.path.lexists(p):
        if not os.path.isdir(p):
            return "it is not a directory"
        return _cannot_create_in(p)
    parent = os.path.dirname(p)
    if not os.path.exists(parent):
        return f"no such directory {_nearest_missing(parent)} (only {os.path.basename(p)} itself is created)"
    if not os.path.isdir(parent):
        return f"{_nearest_file(parent)} is not a directory"
    why = _cannot_create_in(parent)
    if why is None:
        new_folders.add(p)
    return why


def _nearest_missing(path: str) -> str:
    """The first folder of ``path`` that does not exist."""
    while not os.path.exists(os.path.dirname(path)) and os.path.dirname(path) != path:
        path = os.path.dirname(path)
    return path


def _nearest_file(path: str) -> str:
    """The part of ``path`` that exists and is not a folder."""
    while not os.path.exists(path) and os.path.dirname(path) != path:
        path = os.path.dirname(path)
    return path


def _cannot_create_in(folder: str) -> str | None:
    """Why a file cannot be created in ``folder``, found by creating one (and removing it):
    permissions say nothing to root, nor about ``/proc`` or a read-only file system."""
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"permission denied in {folder}"
    name = os.path.join(folder, f".cplus-probe-{os.getpid()}-{os.urandom(4).hex()}")
    try:
        fd = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as exc:
        return f"cannot create files in {folder} ({exc.strerror})"
    os.close(fd)
    os.remove(name)
    return None


def output_problem(path: str) -> str | None:
    """Why ``path`` cannot be written as an output (the rules of :func:`check_paths` for one
    file, without inputs), or None."""
    return _file_problem(path) if path else "an empty file name"
