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

def run_words(code: tuple[int, ...], clumps: tuple[tuple[int, tuple[int, ...], int], ...] = ((0, (), 0),)
              ) -> Firmware:
    data = tiny_rxe(code, toc=[(TC.UBYTE, 0, 0)], static=b"\0", clumps=clumps)
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


@pytest.mark.parametrize("begin, end, error", [
    # the dependent runs: its own FINCLUMP 0 0 (it has none) is the mark
    (0, 0, "dependents 0..0 of clump 1, which has 0 at pc 3 (0x0003), clump 1"),
    (-1, -1, None),  # -1 -1 schedules nobody
    # -1 only with -1: a begin of -1 is not "from the last one", nor "none"
    (-1, 0, "dependents -1..0 of clump 0, which has 1 at pc 0 (0x0000), clump 0"),
])
def test_finclump_of_a_clump_with_a_dependent(begin, end, error):
    """Clump 0 has clump 1 as its one dependent (fire count 1). FINCLUMP's range is of
    indexes into that list, -1 -1 for none (the executable file specification); any other
    range outside the list the emulator refuses rather than read past the list (the
    specification does not define it)."""
    fw = run_words((0x602A, begin & 0xFFFF, end & 0xFFFF, 0x602A, 0, 0),
                   clumps=((0, (1,), 0), (1, (), 3)))
    assert fw.program_errors == ([] if error is None else [f"program t.rxe aborted: FINCLUMP: {error}"])


@pytest.mark.parametrize("target", [1, 2, 0xFFFF])
def test_finclumpimmed_of_a_clump_that_does_not_exist_stops_the_program(target):
    fw = run_words((0x402B, target))
    assert fw.program_errors == [f"program t.rxe aborted: FINCLUMPIMMED: clump {target} does not exist "
                                 "at pc 0 (0x0000), clump 0"]


# -- strings and conversions ---------------------------------------------------------------------

STRINGS = """
string sa = "ab", se = "", sc = "cd", sabcd = "abcd", s12 = "12", sabc = "abc", s4 = "wxyz", s5 = "vwxyz";
string r;
byte ba[];
float f, fneg = -4.0, fbig = 100000000.0, fx = 2.25;
long past, n, err, lv = 0x01020304, lt = 7;
byte bt = 9, b3[] = {1, 2, 3}, zeros[];
string sa1 = "a";
unsigned long two = 2, n300 = 300, one = 1, four = 4, five = 5, ten = 10, zero = 0, seven = 7;

void put(int box, long v)
{
  string t = NumToStr(v);
  SendMessage(box, t);
}

task main()
{
  asm { strcat r, sa, se, sc
        arrsize n, r }
  SendMessage(0, r); put(0, n);
  asm { strsubset r, sabcd, one, ten
        arrsize n, r }
  SendMessage(1, r); put(1, n);
  asm { strsubset r, sabcd, four, one
        arrsize n, r }
  put(1, n);
  asm { strsubset r, sabcd, five, one
        arrsize n, r }
  put(1, n);
  asm { strtoarr ba, sa
        arrsize n, ba }
  put(2, n);
  asm { arrtostr r, ba
        arrsize n, r }
  SendMessage(2, r); put(2, n);
  asm { strtonum f, past, sabc, zero, seven }
  put(3, f); put(3, past);
  asm { strtonum f, past, s12, zero, seven }
  put(3, f); put(3, past);
  asm { sqrt f, fneg }
  r = NumToStr(f); SendMessage(4, r);
  r = NumToStr(fbig); SendMessage(4, r);
  r = NumToStr(fx); SendMessage(4, r);
  asm { mul f, fbig, fbig
        mul f, f, fbig
        mul f, f, fbig
        mul f, f, fbig
        mul f, f, fbig }
  r = NumToStr(f); SendMessage(4, r);
  asm { flatten r, lv
        arrsize n, r
        unflatten lt, err, r, lt }
  put(5, n); put(5, err); put(5, lt);
  lt = 7;
  asm { unflatten lt, err, sabc, lt }
  put(6, err); put(6, lt);
  asm { unflatten lt, err, s5, lt }
  put(7, err); put(7, lt);
  asm { unflatten lt, err, s4, lt }
  put(8, err); put(8, lt);
  asm { unflatten bt, err, se, bt }
  put(9, err); put(9, bt);
  asm { unflatten b3, err, sa1, b3 }
  put(9, err); put(9, b3[0]);
  asm { strsubset r, sabcd, one, two }
  SendMessage(10, r);
  asm { arrinit zeros, 48, n300
        arrtostr r, zeros
        strtonum f, past, r, zero, seven }
  put(10, f); put(10, past);
}
"""


@pytest.fixture(scope="module")
def strings(tmp_path_factory):
    fw = run_program(compiled(tmp_path_factory.mktemp("strings"), "strings", STRINGS))
    assert fw.program_errors == []
    return fw


@pytest.mark.parametrize("box, expected, what", [
    # a string is its bytes and a NUL (ARRSIZE counts it): STRCAT joins its sources without
    # their NULs, an empty one adding nothing
    (0, ["abcd", "5"], "strcat of ab, an empty string and cd"),
    # STRSUBSET from index 1 takes what is there (the NUL not counted); from the string's
    # length, or past it, it gives the empty string (its NUL alone)
    (1, ["bcd", "4", "1", "1"], "strsubset: a count beyond the end, an index at and past it"),
    # STRTOBYTEARR drops the NUL, BYTEARRTOSTR adds it back
    (2, ["2", "ab", "3"], "strtobytearr and bytearrtostr"),
    # STRINGTONUM where no number starts: the default, and the end is 0 (as C's strtod
    # leaves its end pointer at the start when it converts nothing); "12" ends at 2
    (3, ["7", "0", "12", "2"], "strtonum without a number, then of 12"),
    # NUMTOSTRING of floats: the square root of a negative float is a NaN, spelled "nan" as
    # the firmware's sprintf does; %.2f without trailing zeros; an overflow to infinity "inf"
    (4, ["nan", "100000000", "2.25", "inf"], "numtostring of NaN, 1e8, 2.25, infinity"),
    # FLATTEN of a long is its 4 bytes little-endian (and the NUL); UNFLATTEN of exactly 4
    # bytes into a long reads them with no error; 3 or 5 bytes are an error and the
    # destination gets the template (LEGO's executable file specification: the source's
    # length must be the template's flattened size)
    (5, ["5", "0", "16909060"], "flatten and unflatten of a long"),
    (6, ["1", "7"], "unflatten of 3 bytes into a long"),
    (7, ["1", "7"], "unflatten of 5 bytes into a long"),
    (8, ["0", str(int.from_bytes(b"wxyz", "little"))], "unflatten of wxyz into a long"),
    # the empty string has no byte to give a byte (its NUL is not one)
    # ... and a 1-byte string does not fill a 3-byte array
    (9, ["1", "9", "1", "1"], "unflatten of the empty string into a byte, of a into 3 bytes"),
    # STRSUBSET's count; STRINGTONUM reads a number of any length (300 zeros)
    (10, ["bc", "0", "300"], "strsubset of 2 from 1, strtonum of 300 digits"),
])
def test_string_edges(strings, box, expected, what):
    assert results(strings, box) == expected, what


# -- ports, system calls, clumps ----------------------------------------------------------------

PORTS_AND_WAITS = """
byte ports[] = {2, 0, 3, 255};
long v;
unsigned long t, a, b, ms0 = 0, ms7 = 7;

task other() { SendMessage(1, "o1"); Yield(); SendMessage(1, "o2"); }

task main()
{
  start other;
  Yield();
  SendMessage(1, "m1");
  Yield();
  SendMessage(1, "m2");
  asm { setout ports, Power, 40 }
  asm { getout v, 0, Power }
  string s = NumToStr(v); SendMessage(0, s);
  asm { getout v, 1, Power }
  s = NumToStr(v); SendMessage(0, s);
  asm { getout v, 2, Power }
  s = NumToStr(v); SendMessage(0, s);
  asm { gettick a
        wait2 t, ms7
        gettick b
        sub v, t, a }
  s = NumToStr(v); SendMessage(2, s);
  asm { sub v, b, t }
  s = NumToStr(v); SendMessage(2, s);
  asm { wait2 t, ms0
        sub v, t, b }
  s = NumToStr(v); SendMessage(2, s);
}
"""


def test_setout_to_a_port_list_a_wait_that_reads_the_tick_and_a_task_ending_before_another(tmp_path):
    """SETOUT with an array of ports sets each port that exists (2 and 0; 3 and 255 are
    ignored, as a scalar port beyond the brick is); WAIT with a destination (the enhanced
    firmware's ``wait2 dest, ms``) stores the tick at which it starts waiting, with 7 ms as
    with 0; a clump that ends while another is queued behind it leaves that one to run."""
    fw = run_program(compiled(tmp_path, "ports_waits", PORTS_AND_WAITS))
    assert fw.program_errors == []
    assert results(fw, 0) == ["40", "0", "40"]
    assert sorted(results(fw, 1)) == ["m1", "m2", "o1", "o2"]
    assert results(fw, 2) == ["0", "7", "0"]


def test_getin_of_a_field_past_the_last_stops_the_program(tmp_path):
    """Input fields are 0..5 (INVALID the last): GETIN of field 6 is an error where it runs."""
    rxe = compiled(tmp_path, "getin", """
long v;
task main() { asm { getin v, 0, 5 } SendMessage(0, "5"); asm { getin v, 0, 6 } SendMessage(0, "6"); }
""")
    fw = run_program(rxe)
    assert results(fw, 0) == ["5"]
    assert fw.program_errors == ["program t.rxe aborted: GETIN: input field 6 does not exist at pc 19 "
                                 "(0x0013), clump 0"]


@pytest.mark.parametrize("field", [6, 7, 255])
def test_getin_of_any_field_past_the_last_stops_the_program(tmp_path, field):
    rxe = compiled(tmp_path, "getin", f"long v; task main() {{ asm {{ getin v, 0, {field} }} }}")
    fw = run_program(rxe)
    assert fw.program_errors == [f"program t.rxe aborted: GETIN: input field {field} does not exist at pc 6 "
                                 "(0x0006), clump 0"]


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


@pytest.mark.parametrize("wait", ["while (SensorRaw(S1) < 5000);", "while (SoundState() != 99);"])
def test_a_busy_wait_on_a_sensor_or_a_read_only_system_call_is_cut_short(tmp_path, wait):
    """GETIN and a read-only system call count as polling (``vm._polled``), so the spin
    detector skips the cycles of a loop that only reads them (with an infinitely fast brick)."""
    fw = run_program(compiled(tmp_path, "poll", f"task main() {{ {wait} }}"), ms=3)
    assert fw.program is not None and fw.program_errors == []
    assert fw.program.vm.skipped > 0


def test_arrinit_of_a_byte_array_makes_bytes_that_string_instructions_take(tmp_path):
    """ARRINIT of a byte array (a string's type) from an integer or a float makes bytes: 3 'A',
    2 'B' (66.0); BYTEARRTOSTR, STRCAT (each source without its last byte, taken for a NUL),
    ARRBUILD and FLATTEN take them."""
    rxe = compiled(tmp_path, "arrinit", """
byte ba[], bb[];
string r;
float fv = 66.0;
long n;
task main()
{
  asm { arrinit ba, 65, 3
        arrinit bb, fv, 2
        arrtostr r, ba }
  SendMessage(0, r);
  asm { arrtostr r, bb }
  SendMessage(0, r);
  asm { strcat r, ba, bb }
  SendMessage(1, r);
  asm { arrbuild bb, ba, bb
        arrsize n, bb }
  r = NumToStr(n);
  SendMessage(1, r);
  asm { flatten r, ba }
  SendMessage(1, r);
}
""")
    fw = run_program(rxe)
    assert fw.program_errors == []
    assert results(fw, 0) == ["AAA", "BB"] and results(fw, 1) == ["AAB", "5", "AAA"]
