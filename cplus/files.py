"""Writing an output file by one rule, whoever writes it (the commands' products, a batch's
CSV, a robot task's trajectory and pictures, the execution log and report):

* a path that is a regular file, or nothing yet, is **replaced atomically**: the content is
  written to a temporary file beside it, which is renamed over it once complete (a reader,
  or a run stopped half-way, never sees half a file; the file keeps its permissions);
* a path that exists and is anything else, a device (``/dev/null``, ``/dev/stdout``, a
  terminal), a FIFO, a link, is **written through**: opened and written, never replaced, so
  ``--csv /dev/null`` stays the device and ``--csv /dev/stdout`` reaches standard output.

Nothing here creates a folder: the commands check their output paths before any work
(:mod:`cplus.cli.paths`), and a folder that is missing is an error there unless an option
asks for it.
"""
from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from typing import IO, Any

__all__ = ["replaces", "open_output", "output_path", "write_output"]


def replaces(path: str) -> bool:
    """Whether an output at ``path`` replaces a file (a regular file, or nothing there yet)
    rather than being written through (anything else that exists: a link, a device, a FIFO)."""
    try:
        st = os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return True
    return stat.S_ISREG(st.st_mode)


def _beside(path: str) -> str:
    folder, name = os.path.split(os.path.abspath(path))
    stem, suffix = os.path.splitext(name)
    return os.path.join(folder, f".{stem}.{os.getpid()}.tmp{suffix}")


def _finish(tmp: str, path: str) -> None:
    try:
        mode = stat.S_IMODE(os.lstat(path).st_mode)
    except (FileNotFoundError, NotADirectoryError):
        mode = None
    if mode is not None:
        os.chmod(tmp, mode)
    os.replace(tmp, path)


@contextmanager
def open_output(path: str, mode: str = "w", **kw: Any) -> Iterator[IO[Any]]:
    """``with open_output(path) as f:`` — ``f`` writes ``path`` by the module's rule (``mode``
    ``"w"`` or ``"wb"``; ``kw`` as :func:`open`'s).  An exception inside leaves a regular file
    as it was; a device or FIFO has what was written so far."""
    if "b" not in mode:
        kw.setdefault("encoding", "utf-8")
    if not replaces(path):
        with open(path, mode, **kw) as fh:
            yield fh
        return
    tmp = _beside(path)
    try:
        with open(tmp, mode, **kw) as fh:
            yield fh
            fh.flush()
        _finish(tmp, path)
    finally:
        if os.path.lexists(tmp):
            os.remove(tmp)


@contextmanager
def output_path(path: str) -> Iterator[str]:
    """``with output_path(path) as tmp:`` — for writers that want a file name (matplotlib,
    Pillow, ffmpeg, a library's ``save_json``): write to ``tmp`` (same suffix); on success it
    is put at ``path`` by the module's rule (renamed over a regular file; copied into a
    device or FIFO, the temporary file kept in a private temporary folder meanwhile)."""
    if replaces(path):
        tmp = _beside(path)
        try:
            yield tmp
            _finish(tmp, path)
        finally:
            if os.path.lexists(tmp):
                os.remove(tmp)
        return
    import shutil
    import tempfile
    folder = tempfile.mkdtemp(prefix="cplus-out-")
    try:
        tmp = os.path.join(folder, "out" + os.path.splitext(path)[1])
        yield tmp
        with open(tmp, "rb") as src, open(path, "wb") as dst:
            shutil.copyfileobj(src, dst)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def write_output(path: str, data: str | bytes) -> None:
    """Write ``data`` (text as UTF-8) to ``path`` by the module's rule."""
    with open_output(path, "wb" if isinstance(data, bytes) else "w") as fh:
        fh.write(data)
