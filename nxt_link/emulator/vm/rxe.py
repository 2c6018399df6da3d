"""Loader of NXT executables (``.rxe``): header, dataspace, clumps, codespace.

Layout (LEGO MINDSTORMS NXT Executable File Specification v2.0 and the
firmware's ``cCmdReadFileHeader``/``cCmdActivateProgram``), all words
little-endian, each segment starting on an even offset:

* file header: ``"MindstormsNXT\\0"``, version (major, minor byte), then 11
  words: dataspace entry count, dataspace size, static size, defaults size,
  offset and size of the dynamic defaults, memory-manager head and tail, dope
  vector array offset, clump count, code word count;
* dataspace table of contents (DSTOC): 4 bytes per entry (type code, flags,
  offset — or member count of a cluster); an array entry is followed by its
  element type, a cluster by its members;
* default values: the static ones, in TOC order, for every top-level entry
  without the "default default" flag (bit 0), then the dynamic ones: the bytes
  of the dope-vector array and of the arrays' initial contents;
* clump records (fire count, dependent count, first code word), then the
  dependent lists;
* codespace: the clumps' instructions, back to back, up to the end of file.

Everything the firmware checks is checked here, and more (so that a damaged
file fails at load time with a message instead of misbehaving later): a
refusal raises :class:`~nxt_link.emulator.vm.errors.RxeError` naming the file and what
is wrong. Instructions are decoded by :func:`decode_clump`; an undecodable one
is kept as an :class:`Instruction` with ``error`` set, which the interpreter
reports only if it is executed (as the firmware does).
"""
from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any

from nxt_link.emulator.vm.errors import RxeError
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.values import DType, Mutex, default_value

__all__ = ["Executable", "Clump", "Instruction", "load_rxe", "decode_clump",
           "FORMAT_STRING", "POOL_SIZE", "CLUMP_RECORD_POOL_BYTES"]

FORMAT_STRING = b"MindstormsNXT\0"
HEADER_SIZE = 38
#: the firmware's memory pool (``POOL_MAX_SIZE``)
POOL_SIZE = 32768
#: bytes a run-time clump record takes in the pool (``sizeof(CLUMP_REC)`` on the ARM)
CLUMP_RECORD_POOL_BYTES = 28
#: oldest file version the firmware accepts (``VM_OLDEST_COMPATIBLE_VERSION``)
_OLDEST_MINOR = 4
_NEWEST_MAJOR = 1
_DEFAULT_DEFAULT = 0x01
_NOT_A_CLUMP = 0xFF
_NOT_A_DS_ID = 0xFFFF
VAR_INSTR_SIZE = 0xE


@dataclass(frozen=True, slots=True)
class Clump:
    """A clump record: where its code is and whom it schedules when it finishes."""

    index: int
    fire_count: int
    dependents: tuple[int, ...]
    code_start: int  # word index into the codespace
    code_end: int  # last word of the clump (inclusive)


@dataclass(frozen=True, slots=True)
class Instruction:
    """One decoded instruction.

    ``args`` are the raw 16-bit argument words (for a short instruction: the
    resolved dataspace/clump arguments, as the firmware computes them).
    ``error`` is set for a word sequence that is not a valid instruction.
    """

    pc: int
    opcode: int
    cc: int
    args: tuple[int, ...]
    words: int
    short: bool = False
    error: str | None = None


@dataclass(eq=False)
class Executable:
    """A loaded program: what the firmware inflates at activation."""

    name: str
    version: tuple[int, int]
    dataspace_size: int
    static_size: int
    types: list[DType]  # one node per TOC entry (index = DS id)
    slots: list[int]  # DS ids with storage of their own (top-level scalars, arrays, mutexes)
    top_level: list[int]  # DS ids of the top-level entries (clusters included)
    initial: dict[int, Any]  # initial value per slot
    clumps: tuple[Clump, ...]
    code: tuple[int, ...]  # unsigned 16-bit code words

    def initial_values(self) -> dict[int, Any]:
        """Fresh copies of the initial values (a program run owns its data)."""
        from nxt_link.emulator.vm.values import copy_value
        out: dict[int, Any] = {}
        for i, v in self.initial.items():
            t = self.types[i]
            out[i] = Mutex(v.owner) if isinstance(v, Mutex) else copy_value(t, v)
        return out


def _u16(data: bytes, off: int) -> int:
    return int(data[off] | (data[off + 1] << 8))


def load_rxe(data: bytes, name: str = "program.rxe") -> Executable:
    """Parse and validate an ``.rxe`` image; raise :class:`RxeError` if the
    firmware would refuse it (or if it would only fail later)."""
    return _Loader(bytes(data), name).load()


class _Loader:
    def __init__(self, data: bytes, name: str) -> None:
        self.data = data
        self.name = name

    def fail(self, message: str) -> RxeError:
        return RxeError(f"{self.name}: {message}")

    # -- header -----------------------------------------------------------------

    def load(self) -> Executable:
        d = self.data
        if len(d) < len(FORMAT_STRING) or d[:len(FORMAT_STRING)] != FORMAT_STRING:
            if d.startswith(b"NXTBINARY"):
                raise self.fail("a native NXTBINARY image, not a bytecode program")
            raise self.fail("not an NXT executable (no 'MindstormsNXT' file header)")
        if len(d) < HEADER_SIZE:
            raise self.fail(f"truncated: {len(d)} bytes, the file header alone has {HEADER_SIZE}")
        major, minor = d[14], d[15]
        if minor < _OLDEST_MINOR or major > _NEWEST_MAJOR:
            raise self.fail(f"file version {major}.{minor} is not supported by firmware 1.28 "
                            f"(0.{_OLDEST_MINOR} to {_NEWEST_MAJOR}.x)")
        (ds_count, ds_size, static_size, defaults_size, dyn_off, dyn_size, mm_head, mm_tail,
         dva_offset, clump_count, code_count) = struct.unpack_from("<11H", d, 16)
        self.ds_count, self.ds_size, self.static_size = ds_count, ds_size, static_size
        if clump_count == 0 or clump_count >= _NOT_A_CLUMP:
            raise self.fail(f"{clump_count} clumps (a program has 1 to 254)")
        if code_count == 0:
            raise self.fail("no code")
        if ds_size == 0:
            raise self.fail("empty dataspace")
        off = HEADER_SIZE
        toc_off = off
        off += 4 * ds_count
        off += off % 2
        defaults_off = off
        off += defaults_size
        off += off % 2
        clumps_off = off
        if clumps_off + 4 * clump_count > len(d):
            raise self.fail(f"truncated: the clump records end at byte {clumps_off + 4 * clump_count}, "
                            f"the file has {len(d)} bytes")
        records = [struct.unpack_from("<BBH", d, clumps_off + 4 * i) for i in range(clump_count)]
        off = clumps_off + 4 * clump_count + sum(r[1] for r in records)
        off += off % 2
        code_off = off
        expected = code_off + 2 * code_count
        if expected > len(d):
            raise self.fail(f"truncated: the header promises {code_count} code words ending at byte "
                            f"{expected}, the file has {len(d)} bytes")
        if expected < len(d):
            raise self.fail(f"{len(d) - expected} bytes of garbage after the codespace "
                            f"(the header says the file ends at byte {expected})")
        if dyn_off + dyn_size != defaults_size:
            raise self.fail(f"dynamic defaults ({dyn_off}+{dyn_size}) do not end where the "
                            f"defaults do ({defaults_size})")
        if static_size > ds_size:
            raise self.fail(f"static dataspace ({static_size} bytes) larger than the dataspace "
                            f"({ds_size})")
        pool = clump_count * CLUMP_RECORD_POOL_BYTES
        pool += (-pool) % 4
        if pool + ds_size > POOL_SIZE:
            raise self.fail(f"needs {pool + ds_size} bytes of RAM, the brick has {POOL_SIZE}")

        toc = [struct.unpack_from("<BBH", d, toc_off + 4 * i) for i in range(ds_count)]
        types, top = self.parse_toc(toc)
        defaults = d[defaults_off:defaults_off + defaults_size]
        initial, slots = self.inflate(toc, types, top, defaults[:dyn_off], dyn_off)
        dyn = defaults[dyn_off:]
        self.fill_arrays(toc, types, initial, dyn, dva_offset, mm_head, mm_tail,
                         POOL_SIZE - pool - static_size)
        clumps = self.parse_clumps(records, d, clumps_off + 4 * clump_count, code_count)
        code = struct.unpack_from(f"<{code_count}H", d, code_off)
        return Executable(self.name, (major, minor), ds_size, static_size, types, slots, top,
                          initial, clumps, tuple(code))

    # -- table of contents ---------------------------------------------------------

    def parse_toc(self, toc: list[tuple[int, int, int]]) -> tuple[list[DType], list[int]]:
        types: list[DType | None] = [None] * len(toc)

        def build(i: int, depth: int) -> tuple[DType, int]:
            if i >= len(toc):
                raise self.fail("dataspace table of contents ends inside an array or cluster "
                                "definition")
            if depth > 32:
                raise self.fail(f"dataspace entry {i}: types nested more than 32 deep")
            tc, _flags, off = toc[i]
            if tc > TC.FLOAT:
                raise self.fail(f"dataspace entry {i}: unknown type code {tc}")
            if tc == TC.CLUSTER:
                if off == 0:
                    raise self.fail(f"dataspace entry {i}: empty cluster")
                members = []
                j = i + 1
                for _ in range(off):
                    m, j = build(j, depth + 1)
                    members.append(m)
                node = DType(tc, i, members=tuple(members))
            elif tc == TC.ARRAY:
                elem, j = build(i + 1, depth + 1)
                if elem.tc == TC.MUTEX or elem.tc == TC.VOID:
                    raise self.fail(f"dataspace entry {i}: array of {TC.NAMES[elem.tc]}")
                node = DType(tc, i, elem=elem, elem_size=_elem_size(elem),
                             string=elem.tc == TC.UBYTE, nested=_holds_array(elem))
                self.check_element(node)
            else:
                node = DType(tc, i)
                j = i + 1
            types[i] = node
            return node, j

        top = []
        i = 0
        while i < len(toc):
            top.append(i)
            _, i = build(i, 0)
        return [t for t in types if t is not None], top

    def check_element(self, t: DType) -> None:
        """An array's elements hold no mutex nor void (the firmware cannot copy them)."""
        elem = t.elem
        assert elem is not None

        def walk(m: DType) -> None:
            if m.tc == TC.CLUSTER:
                for x in m.members:
                    walk(x)
            elif m.tc == TC.MUTEX or m.tc == TC.VOID:
                raise self.fail(f"dataspace entry {t.index}: array elements of type {elem.name} "
                                f"hold a {TC.NAMES[m.tc]}")

        walk(elem)

    def inflate(self, toc: list[tuple[int, int, int]], types: list[DType], top: list[int],
                static: bytes, dyn_off: int) -> tuple[dict[int, Any], list[int]]:
        """``cCmdInflateDSDefaults``: the static defaults, in TOC order."""
        initial: dict[int, Any] = {}
        slots: list[int] = []
        pos = 0

        def take(n: int, i: int) -> bytes:
            nonlocal pos
            if pos + n > len(static):
                raise self.fail(f"dataspace entry {i}: its default value lies beyond the "
                                f"{len(static)} bytes of static defaults")
            b = static[pos:pos + n]
            pos += n
            return b

        def visit(t: DType) -> None:
            i = t.index
            tc, flags, off = toc[i]
            if t.tc == TC.CLUSTER:
                for m in t.members:
                    visit(m)
                return
            if t.tc != TC.VOID and off + TC.SIZE[t.tc] > self.static_size:
                raise self.fail(f"dataspace entry {i} ({t.name}) at offset {off} lies outside the "
                                f"{self.static_size}-byte static dataspace")
            slots.append(i)
            size = TC.SIZE[t.tc]
            raw = bytes(size) if flags & _DEFAULT_DEFAULT else take(size, i)
            if t.tc == TC.ARRAY:
                initial[i] = _u16(raw, 0)  # dope vector index, resolved in fill_arrays
            elif t.tc == TC.MUTEX:
                initial[i] = Mutex(None if raw[0] == _NOT_A_CLUMP else raw[0])
            elif t.tc == TC.VOID:
                initial[i] = 0
            else:
                initial[i] = _scalar(t.tc, raw, 0)

        for i in top:
            visit(types[i])
        if pos != dyn_off:
            raise self.fail(f"static defaults are {dyn_off} bytes but the dataspace uses {pos}")
        return initial, slots

    def fill_arrays(self, toc: list[tuple[int, int, int]], types: list[DType],
                    initial: dict[int, Any], dyn: bytes, dva_offset: int, head: int,
                    tail: int, room: int) -> None:
        """Decode the arrays' initial contents through the dope-vector array.

        Their pool bytes, nested arrays included, are counted as they are decoded,
        before anything is built, against ``room`` (what the pool has left after the
        static data and the clump records): a file whose dope vectors claim more
        elements than the brick could hold is refused at once instead of being
        inflated."""
        base = self.static_size
        if not base <= dva_offset <= base + len(dyn) - 10:
            raise self.fail(f"dope vector array at offset {dva_offset} lies outside the dynamic "
                            f"defaults ({base}..{base + len(dyn)})")

        def dv(k: int) -> tuple[int, int, int]:
            p = dva_offset - base + 10 * k
            return _u16(dyn, p), _u16(dyn, p + 2), _u16(dyn, p + 4)

        dva_off, dva_es, dva_count = dv(0)
        if dva_off != dva_offset or dva_es != 10:
            raise self.fail("dope vector 0 does not describe the dope vector array")
        if dva_offset - base + 10 * dva_count > len(dyn):
            raise self.fail(f"dope vector array of {dva_count} entries is longer than the "
                            f"dynamic defaults")
        if not (head < dva_count and (tail < dva_count or tail == _NOT_A_DS_ID)):
            raise self.fail(f"memory manager list ({head}..{tail}) outside the dope vector array")

        allocated = 0

        def decode(t: DType, dvi: int, where: str) -> Any:
            nonlocal allocated
            if not 0 < dvi < dva_count:
                raise self.fail(f"{where}: dope vector index {dvi} outside 1..{dva_count - 1}")
            off, es, count = dv(dvi)
            assert t.elem is not None
            if count == 0:
                return default_value(t)
            need = _extent(t.elem, toc)
            if es < need:
                raise self.fail(f"{where}: dope vector {dvi} gives {es}-byte elements, the "
                                f"array's elements ({t.elem.name}) reach byte {need}")
            size = count * t.elem_size
            allocated += size + (-size) % 4
            if allocated > room:
                raise self.fail(f"{where}: dope vector {dvi} claims {count} elements: the initial "
                                f"arrays need more than the {room} bytes of RAM the brick has left "
                                f"for them ({POOL_SIZE} less {POOL_SIZE - room} of static data and "
                                f"clump records)")
            start = off - base
            if start < 0 or start + es * count > len(dyn):
                raise self.fail(f"{where}: initial contents ({count} x {es} bytes at offset "
                                f"{off}) lie outside the dynamic defaults")
            if t.string:
                return bytearray(dyn[start:start + count])
            return [element(t.elem, start + k * es, where) for k in range(count)]

        def element(t: DType, at: int, where: str) -> Any:
            if t.tc == TC.CLUSTER:
                return [element(m, at, where) for m in t.members]
            rel = toc[t.index][2]
            if t.tc == TC.ARRAY:
                return decode(t, _u16(dyn, at + rel), where)
            return _scalar(t.tc, dyn, at + rel)

        for i, v in list(initial.items()):
            t = types[i]
            if t.tc == TC.ARRAY:
                initial[i] = decode(t, v, f"array at dataspace entry {i}")

    # -- clumps -------------------------------------------------------------------------

    def parse_clumps(self, records: list[tuple[int, int, int]], d: bytes, dep_off: int,
                     code_count: int) -> tuple[Clump, ...]:
        n = len(records)
        out = []
        pos = dep_off
        for i, (fire, ndeps, start) in enumerate(records):
            deps = tuple(d[pos:pos + ndeps])
            pos += ndeps
            for dep in deps:
                if dep >= n:
                    raise self.fail(f"clump {i} schedules clump {dep}, there are {n}")
            if start >= code_count:
                raise self.fail(f"clump {i} starts at code word {start}, the codespace has "
                                f"{code_count}")
            if i and start <= records[i - 1][2]:
                raise self.fail(f"clump {i} starts at code word {start}, not after clump {i - 1} "
                                f"(word {records[i - 1][2]})")
            end = records[i + 1][2] - 1 if i + 1 < n else code_count - 1
            out.append(Clump(i, fire, deps, start, end))
        if not any(c.fire_count == 0 for c in out):
            raise self.fail("no clump can start (every clump waits for another one)")
        return tuple(out)


def _scalar(tc: int, data: bytes, off: int) -> Any:
    fmt = {TC.UBYTE: "<B", TC.SBYTE: "<b", TC.UWORD: "<H", TC.SWORD: "<h", TC.ULONG: "<I",
           TC.SLONG: "<i", TC.FLOAT: "<f"}[tc]
    v = struct.unpack_from(fmt, data, off)[0]
    return float(v) if tc == TC.FLOAT else v


def _extent(t: DType, toc: list[tuple[int, int, int]]) -> int:
    """Bytes from an element's start to the end of its last member (the TOC offsets of
    an array's element type are relative to the element)."""
    if t.tc == TC.CLUSTER:
        return max(_extent(m, toc) for m in t.members)
    return toc[t.index][2] + TC.SIZE[t.tc]


def _holds_array(t: DType) -> bool:
    """``t`` is an array or a cluster with an array among its members (at any depth)."""
    if t.tc == TC.CLUSTER:
        return any(_holds_array(m) for m in t.members)
    return t.tc == TC.ARRAY


def _elem_size(t: DType) -> int:
    """Bytes one array element takes (each member aligned to its own size, the
    whole to its largest member: ``cCmdCalcArrayElemSize``)."""
    scalars: list[int] = []

    def walk(x: DType) -> None:
        if x.tc == TC.CLUSTER:
            for m in x.members:
                walk(m)
        else:
            scalars.append(TC.SIZE[x.tc])

    walk(t)
    size = align = 0
    for s in scalars:
        if s:
            size += (-size) % s
            size += s
            align = max(align, s)
    if align:
        size += (-size) % align
    return size


# -- instructions ---------------------------------------------------------------------

#: size in bytes each long opcode is dispatched with (``None``: variable size)
_LONG_SIZES: dict[int, int | None] = {
    0x25: 4, 0x2C: 4, 0x2D: 4, 0x2F: 4, 0x2B: 4, 0x35: 4, 0x29: 4,
    0x02: 6, 0x09: 6, 0x12: 6, 0x36: 6, 0x37: 6, 0x1B: 6, 0x1C: 6, 0x27: 6, 0x2A: 6,
    0x2E: 6, 0x17: 6, 0x28: 6, 0x1D: 6, 0x1F: 6, 0x23: 6, 0x24: 6, 0x34: 6,
    0x00: 8, 0x01: 8, 0x03: 8, 0x04: 8, 0x05: 8, 0x06: 8, 0x07: 8, 0x08: 8,
    0x30: 8, 0x32: 8, 0x33: 8, 0x11: 8, 0x26: 8, 0x15: 8, 0x1A: 8,
    0x16: 10, 0x19: 10, 0x22: 10, 0x1E: 10, 0x20: 12,
    0x31: None, 0x18: None, 0x21: None,
}


def expected_size(opcode: int) -> int | None | bool:
    """Bytes the firmware dispatches ``opcode`` with; None: variable; False: unknown."""
    return _LONG_SIZES.get(opcode, False)


def decode_clump(code: tuple[int, ...], clump: Clump) -> list[Instruction]:
    """The instructions of one clump, in order."""
    out: list[Instruction] = []
    pc = clump.code_start
    end = clump.code_end
    while pc <= end:
        w = code[pc]
        size = (w >> 12) & 0x0F
        if w & 0x0800:
            sop = (w >> 8) & 0x07
            arg = w & 0xFF
            if arg & 0x80:
                arg -= 0x100
            nwords = 1 if sop in (1, 2) else 2
            if pc + nwords - 1 > end:
                out.append(Instruction(pc, sop, 0, (), 1, True,
                                       "short instruction runs past the end of its clump"))
                break
            if sop in (0, 3):
                base = code[pc + 1]
                args: tuple[int, ...] = ((arg + base) & 0xFFFF, base)
            else:
                args = (arg & 0xFFFF,)
            err = None if sop <= 3 else f"short opcode {sop} is not an instruction"
            out.append(Instruction(pc, sop, 0, args, nwords, True, err))
            pc += nwords
            continue
        opcode = w & 0xFF
        cc = (w >> 8) & 0x07
        if size == VAR_INSTR_SIZE:
            if pc + 1 > end:
                out.append(Instruction(pc, opcode, cc, (), 1, False,
                                       "variable-size instruction without its size word"))
                break
            size = code[pc + 1]
        if size < 2 or size % 2:
            out.append(Instruction(pc, opcode, cc, (), 1, False,
                                   f"instruction size {size} bytes is not an instruction"))
            break
        nwords = size // 2
        if pc + nwords - 1 > end:
            out.append(Instruction(pc, opcode, cc, (), nwords, False,
                                   "instruction runs past the end of its clump"))
            break
        out.append(Instruction(pc, opcode, cc, tuple(code[pc + 1:pc + nwords]), nwords))
        pc += nwords
    return out
