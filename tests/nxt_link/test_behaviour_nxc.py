"""The Legolog NXC program compiles with Debian's nbc and agrees with its Python model."""
from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from nxt_link.emulator import legolog_program
from nxt_link.emulator.world import Ports
from nxt_link.programs import behaviour_protocol as bp

NXC = Path(bp.__file__).resolve().parent / "nxc" / "cplus_legolog.nxc"


def defines() -> dict[str, int]:
    out = {}
    for name, value in re.findall(r"^#define\s+(\w+)\s+(0x[0-9A-Fa-f]+|-?\d+)\s*$",
                                  NXC.read_text(), flags=re.M):
        out[name] = int(value, 0)
    return out


def test_nbc_compiles_the_program_to_an_rxe(tmp_path):
    nbc = shutil.which("nbc")
    assert nbc is not None, "nbc is not installed (apt-get install -y nbc)"
    source = tmp_path / NXC.name
    shutil.copy(NXC, source)
    out = tmp_path / bp.PROGRAM_NAME
    proc = subprocess.run([nbc, "-sm-", f"-O={out}", source.name], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    data = out.read_bytes()
    assert data.startswith(b"MindstormsNXT")  # the firmware's executable header
    assert len(data) > 1000


def test_program_file_name_fits_the_firmware():
    assert len(bp.PROGRAM_NAME) <= 19 and bp.PROGRAM_NAME == NXC.stem + ".rxe"


CONSTANTS = (
    [(name, value) for name, value in legolog_program.ROBOT_CONSTANTS.items()]
    + [(f"K_{k.name}", k.value) for k in bp.Kind]
    + [(f"ST_{s.name}", s.value) for s in bp.State]
    + [(f"A_{c.name}", c.value) for c in bp.AckCode]
    + [(f"S_{s.name}", s.value) for s in bp.Status]
    + [(f"B_{b.name}", b.value) for b in bp.Behaviour]
    + [(f"SN_{s.name}", s.value) for s in bp.Sense]
    + [(f"EV_{e.name}", e.value) for e in bp.Event])


@pytest.mark.parametrize("nxc_name, value", CONSTANTS)
def test_nxc_constants_equal_the_python_ones(nxc_name, value):
    assert defines()[nxc_name] == value


def test_every_nxc_constant_is_checked():
    assert set(defines()) == {name for name, _ in CONSTANTS}


def test_the_world_defaults_wire_the_robot_as_the_program_expects():
    p = Ports()
    d = defines()
    assert (p.touch, p.light, p.left, p.right, p.tray) == (
        d["PORT_TOUCH"], d["PORT_LIGHT"], d["PORT_LEFT"], d["PORT_RIGHT"], d["PORT_TRAY"])


def test_program_never_resets_a_motor_counter():
    src = NXC.read_text()
    calls = re.findall(r"\b(OnFwd\w*|OnRev\w*|Off\w*|Coast\w*)\s*\(([^;]*)\)\s*;", src)
    assert calls and all(args.strip().endswith("RESET_NONE") for _, args in calls)
    assert "MotorTachoCount" not in src and "MotorBlockTachoCount" not in src


def test_the_loop_is_legologs_figure_2():
    body = NXC.read_text().split("task main()")[1]
    order = [body.index(s) for s in ("status == STATUS_ABORT", "status == STATUS_PANIC",
                                     "status == STATUS_OK")]
    assert order == sorted(order)
