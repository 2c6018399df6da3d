"""The NXC brick program compiles with Debian's nbc and agrees with its Python model."""
from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from nxt_link.emulator import follower_program
from nxt_link.programs import stream_protocol as sp

NXC = Path(sp.__file__).resolve().parent / "nxc" / "cplus_follow.nxc"


def defines() -> dict[str, int]:
    out = {}
    for name, value in re.findall(r"^#define\s+(\w+)\s+(0x[0-9A-Fa-f]+|\d+)\s*$",
                                  NXC.read_text(), flags=re.M):
        out[name] = int(value, 0)
    return out


def test_nbc_compiles_the_program_to_an_rxe(tmp_path):
    nbc = shutil.which("nbc")
    assert nbc is not None, "nbc is not installed (apt-get install -y nbc)"
    source = tmp_path / NXC.name
    shutil.copy(NXC, source)
    out = tmp_path / "cplus_follow.rxe"
    proc = subprocess.run([nbc, "-sm-", f"-O={out}", source.name], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    data = out.read_bytes()
    assert data.startswith(b"MindstormsNXT")  # the firmware's executable header
    assert len(data) > 1000


def test_program_file_name_fits_the_firmware():
    assert len(sp.PROGRAM_NAME) <= 19 and sp.PROGRAM_NAME == NXC.stem + ".rxe"


@pytest.mark.parametrize("nxc_name, value", [
    ("PROTOCOL_VERSION", sp.PROTOCOL_VERSION),
    ("CMD_INBOX", sp.CMD_INBOX),
    ("RESPONSE_QUEUE", sp.RESPONSE_QUEUE),
    ("MAX_VALUES", sp.MAX_VALUES),
    ("MAX_PORTS", sp.MAX_PORTS),
    ("CONTROL_MS", sp.CONTROL_MS),
    ("MAX_MESSAGE", sp.MAX_MESSAGE),
    ("MAX_BATCH", follower_program.MAX_BATCH),
    ("LOG_VALUES_PER_MESSAGE", sp.LOG_VALUES_PER_MESSAGE),
] + [(f"K_{k.name}", k.value) for k in sp.Kind]
  + [(f"ST_{s.name}", s.value) for s in sp.State]
  + [(f"C_{c.name}", c.value) for c in sp.Code])
def test_nxc_constants_equal_the_python_ones(nxc_name, value):
    assert defines()[nxc_name] == value


def test_program_reads_angles_without_resetting_them():
    src = NXC.read_text()
    # every motor command keeps the counters (RESET_NONE); angles come from RotationCount
    calls = re.findall(r"\b(OnFwd\w*|OnRev\w*|Off\w*|Coast\w*)\s*\(([^;]*)\)\s*;", src)
    assert calls and all(args.strip().endswith("RESET_NONE") for _, args in calls)
    assert "MotorTachoCount" not in src and "MotorBlockTachoCount" not in src
    assert "MotorRotationCount" in src
