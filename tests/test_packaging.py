"""What `pip install .` installs: every module and data file of the three packages.

The tests run on an editable install, which sees the source tree; only a built wheel shows a
package or a data file that the packaging configuration leaves out (as happened once with
`nxt_link.vm`), so build one and compare it with the tree.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("cplus", "trajectory", "nxt_link")


def test_the_wheel_holds_every_file_of_the_packages(tmp_path):
    # setuptools builds in the project's folder (build/, *.egg-info): build a copy, so that the
    # test leaves the source tree as it found it
    src, out = tmp_path / "src", tmp_path / "wheel"
    junk = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    for pkg in PACKAGES:
        shutil.copytree(ROOT / pkg, src / pkg, ignore=junk)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    def tree_top() -> list[str]:
        """The project folder's entries, less the caches that other tests (mypy, ruff, pytest)
        may create meanwhile in a parallel run."""
        return sorted(p.name for p in ROOT.iterdir() if not p.name.endswith("_cache"))
    before = tree_top()
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                           "-w", str(out), str(src)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert tree_top() == before
    wheel = next(out.glob("cplus-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    tree = {str(p.relative_to(ROOT)) for pkg in PACKAGES for p in (ROOT / pkg).rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".pyc"}
    assert len(tree) > 50
    missing = sorted(tree - names)
    assert not missing, f"not installed by `pip install .`: {missing}"
