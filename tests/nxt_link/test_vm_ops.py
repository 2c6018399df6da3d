"""Each instruction's edge cases, as the NXT firmware defines them (the LEGO MINDSTORMS NXT
Executable File Specification, and the enhanced firmware where it differs), run on the
interpreter: small NXC programs whose NBC assembly says exactly which instruction runs, and
executables written word by word (:func:`vmtools.tiny_rxe`) for what no compiler writes.
The Python model (:mod:`nxt_link.emulator.firmware`'s follower) has no instructions of its own, so
these run on the interpreter alone."""
from __future__ import annotations

from pathlib import Path

import pytest
from vmtools import FINCLUMP, results, run_program, tiny_rxe

from nxt_link.emulator.firmware import Firmware
from nxt_link.emulator.vm import compile_nxc
from nxt_link.emulator.vm.opcodes import TC

pytestmark = pytest.mark.timeout(300)

EDGES = """
long lmin = -2147483648;
long m1 = -1;
long q, r;
int arr[] = {1, 2, 3};
int arr2[];
byte ai[];
unsigned long n = 65539;
string s = "1.5.3x";
float f;
long past;
char cmin = -128, cm1 = -1, cq;
int imin = -32768, iq;
long minus4 = -4, root;
float fa = 1.5, fb = 2.5;
long flags = 0;

void put(int box, long v)
{
  string t = NumToStr(v);
  SendMessage(box, t);
}

task main()
{
  asm { div q, lmin, m1 }
  asm { mod r, lmin, m1 }
  put(0, q); put(0, r);
  asm { replace arr2, arr, 3, 9 }
  asm { replace arr, arr, 3, 9 }
  put(1, ArrayLen(arr)); put(1, arr[2]); put(1, ArrayLen(arr2)); put(1, arr2[2]);
  asm { replace arr, arr, 2, 9 }
  put(2, arr[0]); put(2, arr[1]); put(2, arr[2]);
  asm { arrinit ai, 7, n }
  put(3, ArrayLen(ai)); put(3, ai[2]);
  asm { strtonum f, past, s, 0, 0 }
  put(4, f * 10); put(4, past);
  asm { div cq, cmin, cm1 }
  asm { div iq, imin, cm1 }
  asm { sqrt root, minus4 }
  put(5, cq); put(5, iq); put(5, root);
  asm {
    brcmp LT, Lless, fa, fb
    add flags, flags, 1
  Lless:
    mul flags, flags, 10
    brcmp LT, Lmore, fb, fa
    add flags, flags, 1
  Lmore:
  }
  put(6, flags);
}
"""


def compiled(tmp_path: Path, name: str, text: str) -> bytes:
    src = tmp_path / f"{name}.nxc"
    src.write_text(text)
    return compile_nxc(src).rxe


@pytest.fixture(scope="module")
def edges(tmp_path_factory):
    fw = run_program(compiled(tmp_path_factory.mktemp("edges"), "edges", EDGES))
    assert fw.program_errors == []
    return fw


@pytest.mark.parametrize("box, expected, what", [
    # C's division toward zero in 32 bits: INT_MIN / -1 overflows and wraps to INT_MIN;
    # its remainder is 0
    (0, ["-2147483648", "0"], "div and mod of INT_MIN by -1"),
    # REPLACE at an index past the end (the array's length) changes nothing, in place or
    # into a copy; the last element itself is replaced
    (1, ["3", "3", "3", "3"], "replace at the length: nothing, in place and into a copy"),
    (2, ["1", "2", "9"], "replace of the last element"),
    # ARRINIT's count is a UWORD: 65539 (0x10003) is 3 elements
    (3, ["3", "7"], "arrinit with a count beyond 16 bits"),
    # STRINGTONUM reads one decimal point: "1.5.3x" is 1.5, and its end is the second dot
    (4, ["15", "3"], "strtonum stops at a second dot"),
    # a signed division wraps to its destination's width: -128 / -1 in a char is -128, and
    # -32768 / -1 in an int -32768; SQRT of an integer is 0, cCmdUnop2's default case (as
    # nxt_link.emulator.vm.poly.int_unop has it; only SQRT of a float computes a root)
    (5, ["-128", "-32768", "0"], "div wrapped to a char and an int, sqrt of a long"),
    # BRCMP between floats: 1.5 < 2.5 branches (flags stays 0, then 0 * 10), 2.5 < 1.5 does not (+ 1)
    (6, ["1"], "brcmp of floats"),
])
def test_instruction_edges(edges, box, expected, what):
    assert results(edges, box) == expected, what


def test_a_mutex_goes_to_its_waiters_first_come_first_served(tmp_path):
    rxe = compiled(tmp_path, "mutex", """
mutex m;

task a() { Acquire(m); SendMessage(0, "a"); Release(m); }
task b() { Wait(5); Acquire(m); SendMessage(0, "b"); Release(m); }

task main()
{
  Acquire(m);
  start a;
  start b;
  Wait(10);
  SendMessage(0, "main");
  Release(m);
}
""")
    fw = run_program(rxe)
    assert fw.program_errors == [] and results(fw, 0) == ["main", "a", "b"]


PORTS = """
byte pin = PIN;
byte pout = POUT;
long v;

task main()
{
  asm { getin v, pin, RawValue }
  asm { getout v, pout, Power }
  SendMessage(0, "done");
}
"""


@pytest.mark.parametrize("pin, pout, error", [
    (3, 2, None),                                      # the last input port, the last output port
    (4, 2, "GETIN: input port 4 does not exist at pc 6 (0x0006)"),
    (255, 0, "GETIN: input port 255 does not exist at pc 6 (0x0006)"),
    (0, 3, "GETOUT: output port 3 does not exist at pc 10 (0x000A)"),
])
def test_ports_beyond_the_bricks_stop_the_program(tmp_path, pin, pout, error):
    fw = run_program(compiled(tmp_path, "ports", PORTS.replace("PIN", str(pin)).replace("POUT", str(pout))))
    if error is None:
        assert fw.program_errors == [] and results(fw, 0) == ["done"]
    else:
        assert fw.program_errors == [f"program t.rxe aborted: {error}, clump 0"] and results(fw, 0) == []



MORE = """
long n;
float fa[] = {1.5, 2.5};
float x;
long k = 3;
byte p0 = 0, p3 = 3;
long v;

task main()
{
  n++;
  Wait(0);
  string t = NumToStr(n);
  SendMessage(0, t);
  asm { setout p0, Power, 50 }
  asm { setout p3, Power, 60 }
  asm { getout v, p0, Power }
  t = NumToStr(v);
  SendMessage(0, t);
  asm { index x, fa, k }
  SendMessage(0, "not here");
}
"""


def test_a_yield_a_scalar_port_and_an_index_past_the_end_of_a_float_array(tmp_path):
    """WAIT 0 gives the CPU away and goes on after it (once: ``n`` is 1); SETOUT to a port in a
    scalar sets it, to port 3 is ignored; INDEX past the end (not only at it) of an array of
    floats stops the program."""
    fw = run_program(compiled(tmp_path, "more", MORE))
    assert results(fw, 0) == ["1", "50"]
    assert fw.program_errors == ["program t.rxe aborted: INDEX: index 3 is outside the array at dataspace "
                                 "entry 28 (2 elements) at pc 72 (0x0048), clump 0"]

# -- written word by word ------------------------------------------------------------------------

def run_words(code: tuple[int, ...]) -> Firmware:
    data = tiny_rxe(code, toc=[(TC.UBYTE, 0, 0)], static=b"\0")
    fw = Firmware(flash_files={"t.rxe": data})
    fw.start_program_now("t.rxe")
    fw.tick()
    assert fw.program is None
    return fw


#: FINCLUMP 0 0 in a clump without dependents: a run-time error, the mark of a branch taken
TAKEN = "program t.rxe aborted: FINCLUMP: dependents 0..0 of clump 0, which has 0 at pc 6 (0x0006), clump 0"


@pytest.mark.parametrize("cc, taken", [(0, False), (1, False), (2, True), (3, True), (4, True), (5, False)])
def test_brtst_without_an_operand_compares_zero_with_zero(cc, taken):
    """BRTST cc, +6, NOT_A_DS_ID: no operand reads as 0, so LTEQ, GTEQ and EQ branch, LT, GT
    and NEQ do not (the enhanced firmware's cCmdCompare of 0 with 0)."""
    fw = run_words((0x6027 | cc << 8, 6, 0xFFFF) + FINCLUMP + (0x602A, 0, 0))
    assert fw.program_errors == ([TAKEN] if taken else [])


@pytest.mark.parametrize("begin, end", [(0, 0), (-1, 0), (0, 1)])
def test_finclump_of_dependents_a_clump_does_not_have_stops_the_program(begin, end):
    fw = run_words((0x602A, begin & 0xFFFF, end & 0xFFFF))
    assert fw.program_errors == [f"program t.rxe aborted: FINCLUMP: dependents {begin}..{end} of clump 0, "
                                 "which has 0 at pc 0 (0x0000), clump 0"]


@pytest.mark.parametrize("target", [1, 2, 0xFFFF])
def test_finclumpimmed_of_a_clump_that_does_not_exist_stops_the_program(target):
    fw = run_words((0x402B, target))
    assert fw.program_errors == [f"program t.rxe aborted: FINCLUMPIMMED: clump {target} does not exist "
                                 "at pc 0 (0x0000), clump 0"]


@pytest.mark.parametrize("call, members, error", [
    # read only (it changes nothing outside the program)
    ("SoundGetState", "byte state[]; byte flags;", "argument 11 is a ubyte[], a scalar is needed"),
    ("SoundSetState", "byte result; byte state[]; byte flags;",
     "argument 12 is a ubyte[], a scalar is needed"),
])
def test_a_system_call_with_arguments_it_cannot_take_stops_the_program_naming_it(tmp_path, call, members, error):
    """A system call whose cluster has an array where it writes or reads a number stops the
    program with an error naming the call, read-only call or not (the emulator's choice: the
    specification does not say what a firmware makes of such a cluster)."""
    rxe = compiled(tmp_path, "syscall", f"""
struct Args {{ {members} }};
Args args;
task main() {{ SendMessage(0, "before"); asm {{ syscall {call}, args }} SendMessage(0, "after"); }}
""")
    fw = run_program(rxe)
    assert results(fw, 0) == ["before"]
    assert fw.program_errors == [f"program t.rxe aborted: SYSCALL {call}: {error} at pc 15 (0x000F), clump 0"]
