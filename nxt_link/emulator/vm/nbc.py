"""Compiling NXC programs with ``nbc`` (NeXT Byte Codes), once, into a cache.

:func:`compile_nxc` runs ``nbc -O=... -Y=...`` on a copy of the source in a
temporary directory and returns the executable and its symbol table;
:func:`cached_compile` keeps both under ``~/.cache/cplus/rxe`` (or
``$XDG_CACHE_HOME/cplus/rxe``), keyed by a hash of the source and the nbc
version, so the project's programs are compiled once per change, not per run.
The compiled ``.rxe`` never goes into the repository.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

from nxt_link.programs import NXC_DIR

__all__ = ["NbcError", "NbcMissingError", "Compiled", "compile_nxc", "cached_compile",
           "cache_dir", "follower_source", "nbc_path"]


class NbcError(RuntimeError):
    """nbc refused the source (its messages are in the text)."""


class NbcMissingError(NbcError):
    """nbc is not installed."""


@dataclass(frozen=True)
class Compiled:
    rxe: bytes
    symbols: str
    path: Path | None = None


def nbc_path() -> str | None:
    return shutil.which("nbc")


def follower_source() -> Path:
    """``nxt_link/programs/nxc/cplus_follow.nxc``."""
    return NXC_DIR / "cplus_follow.nxc"


def cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "cplus" / "rxe"


def _nbc_version(nbc: str) -> str:
    proc = subprocess.run([nbc], capture_output=True, text=True, timeout=60)
    return (proc.stdout + proc.stderr).splitlines()[0] if (proc.stdout + proc.stderr) else ""


def compile_nxc(source: Path | str, *, name: str | None = None,
                timeout_s: float = 120.0) -> Compiled:
    """Compile an NXC (or NBC) file; raise :class:`NbcMissingError` or :class:`NbcError`."""
    nbc = nbc_path()
    if nbc is None:
        raise NbcMissingError("nbc is not installed (apt-get install nbc)")
    src = Path(source)
    stem = name or src.stem
    with tempfile.TemporaryDirectory(prefix="cplus-nbc-") as tmp:
        copy = Path(tmp) / src.name
        shutil.copy(src, copy)
        out = Path(tmp) / f"{stem}.rxe"
        sym = Path(tmp) / f"{stem}.sym"
        proc = subprocess.run([nbc, "-sm-", f"-O={out}", f"-Y={sym}", copy.name], cwd=tmp,
                              capture_output=True, text=True, timeout=timeout_s)
        if proc.returncode != 0 or not out.exists():
            text = (proc.stdout + proc.stderr).strip().replace(str(copy), src.name)
            raise NbcError(f"nbc could not compile {src.name}: {text}")
        return Compiled(out.read_bytes(), sym.read_text() if sym.exists() else "")


def cached_compile(source: Path | str, *, directory: Path | None = None) -> Compiled:
    """:func:`compile_nxc`, once per (source, nbc version); the result is cached."""
    nbc = nbc_path()
    if nbc is None:
        raise NbcMissingError("nbc is not installed (apt-get install nbc)")
    src = Path(source)
    key = hashlib.sha256(src.read_bytes() + _nbc_version(nbc).encode()).hexdigest()[:16]
    d = directory or cache_dir()
    rxe, sym = d / f"{src.stem}-{key}.rxe", d / f"{src.stem}-{key}.sym"
    if rxe.exists() and sym.exists():
        return Compiled(rxe.read_bytes(), sym.read_text(), rxe)
    compiled = compile_nxc(src)
    d.mkdir(parents=True, exist_ok=True)
    # write under temporary names and rename: concurrent runs never see half a file
    for path, data in ((sym, compiled.symbols.encode()), (rxe, compiled.rxe)):
        fd, tmp = tempfile.mkstemp(dir=d, prefix=path.name, suffix=".tmp")
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    return Compiled(compiled.rxe, compiled.symbols, rxe)
