"""Data movement and arrays: ``mov``, ``set``, ``arrsize``, ``index``, ``replace``,
``arrinit``, ``arrsubset``, ``arrbuild``.

Moves and element accesses between integer types are source templates; every
instruction that gives a top-level array a new size accounts for it in the
32 KB pool (:meth:`nxt_link.emulator.vm.core.VMCore._account`). An index outside an
array faults for ``index``; ``replace`` outside it changes nothing, as the
firmware does.
"""
from __future__ import annotations

from typing import Any

from nxt_link.emulator.vm import poly
from nxt_link.emulator.vm.core import NOT_A_DS_ID, Fault, Op, VMCore, index_fault, out_of_memory
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.rxe import POOL_SIZE
from nxt_link.emulator.vm.templates import indent, wrap_src
from nxt_link.emulator.vm.values import INT_TYPES, M32, DType, copy_value, held_bytes, store, wrap

__all__ = ["DataOps"]


class DataOps(VMCore):
    """Compilers of the move and array instructions."""

    def _mov(self, d: int, s: int, nxt: int, name: str) -> Op:
        self._arg(d, name)
        self._arg(s, name)
        m = self.mem
        td, ts = self.types[d], self.types[s]
        if td.tc in INT_TYPES and ts.tc in INT_TYPES:
            dt = td.tc
            if td.tc == ts.tc or (td.tc == TC.SLONG and ts.tc in (TC.UBYTE, TC.SBYTE, TC.UWORD,
                                                                   TC.SWORD)):
                return self._fuser.template(f"m[{d}] = m[{s}]")
            if dt == TC.UBYTE:
                return self._fuser.template(f"m[{d}] = m[{s}] & 0xFF")
            if dt == TC.ULONG:
                return self._fuser.template(f"m[{d}] = m[{s}] & 0xFFFFFFFF")
            if dt == TC.SLONG:  # from a ulong
                return self._fuser.template(
                    f"v = m[{s}]\nm[{d}] = v - 0x100000000 if v & 0x80000000 else v")
            return self._fuser.template(wrap_src(dt, f"m[{s}]", f"m[{d}]"))
        if td.tc == TC.FLOAT and ts.tc == TC.FLOAT:
            return self._fuser.template(f"m[{d}] = m[{s}]")
        if td.tc == TC.ARRAY and ts.tc == TC.ARRAY and td.string and ts.string:
            def k() -> int:
                v = bytearray(m[s])
                self._account(d, v)
                m[d] = v
                return nxt
            return k
        get_s, set_d = self._getter(s), self._setter(d)

        def gen() -> int:
            try:
                set_d(poly.convert(td, ts, get_s()))
            except poly.PolyError as exc:
                raise Fault(f"{name}: {exc}") from None
            return nxt
        return gen

    def _set(self, d: int, imm: int, nxt: int) -> Op:
        self._scalar_arg(d, "SET")
        m = self.mem
        v = store(self.types[d].tc, imm)
        if isinstance(v, int):
            return self._fuser.template(f"m[{d}] = {v}")

        def f() -> int:
            m[d] = v
            return nxt
        return f

    def _arrsize(self, d: int, s: int, nxt: int) -> Op:
        self._scalar_arg(d, "ARRSIZE")
        self._array_arg(s, "ARRSIZE")
        return self._fuser.template(f"m[{d}] = store({self.types[d].tc}, len(m[{s}]))")

    def _index(self, d: int, s: int, i: int, nxt: int) -> Op:
        self._arg(d, "INDEX")
        ts = self._array_arg(s, "INDEX")
        idx = self._int_reader(i, "INDEX")
        m = self.mem
        td = self.types[d]
        te = ts.elem
        assert te is not None
        if td.tc in INT_TYPES and te.tc in INT_TYPES:
            dt = td.tc
            same = dt == te.tc or dt == TC.SLONG and te.tc != TC.ULONG
            return self._fuser.template(
                f"k = {self._int_src(i, 'INDEX')} & 0xFFFFFFFF\n"
                f"arr = m[{s}]\n"
                f"if k >= len(arr):\n"
                f"    index_fault(k, {s}, arr)\n"
                + (f"m[{d}] = arr[k]" if same else wrap_src(dt, "arr[k]", f"m[{d}]")))
        set_d = self._setter(d)

        def g() -> int:
            k = idx() & M32
            arr = m[s]
            if k >= len(arr):
                index_fault(k, s, arr)
            try:
                set_d(poly.convert(td, te, copy_value(te, arr[k])))
            except poly.PolyError as exc:
                raise Fault(f"INDEX: {exc}") from None
            return nxt
        return g

    def _replace(self, d: int, s: int, i: int, v: int, nxt: int) -> Op:
        td = self._array_arg(d, "REPLACE")
        ts = self._array_arg(s, "REPLACE")
        self._arg(v, "REPLACE")
        idx = self._int_reader(i, "REPLACE")
        m = self.mem
        tv = self.types[v]
        te = td.elem
        assert te is not None
        get_v = self._getter(v)
        copy = d != s
        nested = td.nested
        if te.tc in INT_TYPES and tv.tc in INT_TYPES:
            et = te.tc
            same = et == tv.tc
            if not copy:
                return self._fuser.template(
                    f"arr = m[{d}]\n"
                    f"k = {self._int_src(i, 'REPLACE')} & 0xFFFFFFFF\n"
                    f"if k < len(arr):\n"
                    + (f"    arr[k] = m[{v}]" if same
                       else indent(wrap_src(et, f"m[{v}]", "arr[k]"))))

            def f() -> int:
                if copy:
                    new = poly.convert(td, ts, m[s])
                    self._account(d, new)
                    m[d] = new
                arr = m[d]
                k = idx() & M32
                if k < len(arr):
                    arr[k] = m[v] if same else wrap(et, m[v])
                return nxt
            return f

        def g() -> int:
            try:
                if copy:
                    new = poly.convert(td, ts, m[s])
                    self._account(d, new)
                    m[d] = new
                arr = m[d]
                k = idx() & M32
                n = len(arr)
                if k >= n:
                    return nxt
                val = get_v()
                if tv.tc != TC.ARRAY or _same_type(te, tv):
                    # one new element (an array replacing a row of an array of arrays,
                    # which firmware 1.29's code would treat as a list of elements)
                    arr[k] = poly.convert(te, tv, copy_value(tv, val))
                else:
                    assert tv.elem is not None
                    for j in range(min(n - k, len(val))):
                        arr[k + j] = poly.convert(te, tv.elem, copy_value(tv.elem, val[j]))
            except poly.PolyError as exc:
                raise Fault(f"REPLACE: {exc}") from None
            if nested:  # new elements may hold bigger arrays
                self._account(d, arr)
            return nxt
        return g

    def _arrinit(self, d: int, v: int, n: int, nxt: int) -> Op:
        td = self._array_arg(d, "ARRINIT")
        self._arg(v, "ARRINIT")
        count = self._int_reader(n, "ARRINIT")
        m = self.mem
        tv = self.types[v]
        te = td.elem
        assert te is not None
        get_v = self._getter(v)

        def f() -> int:
            k = count() & 0xFFFF
            val = get_v()
            try:
                if tv.tc in INT_TYPES:
                    e = store(te.tc, val) if te.is_scalar else None
                    if e is None:
                        raise Fault(f"ARRINIT: {te.name} elements from a {tv.name}")
                    new: Any = bytearray([e]) * k if td.string else [e] * k
                elif te.is_scalar:
                    e = poly.convert(te, tv, val)
                    new = bytearray([e]) * k if td.string else [e] * k
                else:
                    e = poly.convert(te, tv, val)
                    held = held_bytes(te, e) if td.nested else 0
                    if k * held > POOL_SIZE:  # refused before it is built
                        raise Fault("ARRINIT: " + out_of_memory(
                            k * held, f"{k} elements holding {held} bytes of arrays each"))
                    new = [copy_value(te, e) for _ in range(k)]
            except poly.PolyError as exc:
                raise Fault(f"ARRINIT: {exc}") from None
            self._account(d, new)
            m[d] = new
            return nxt
        return f

    def _arrsubset(self, d: int, s: int, i: int, n: int, nxt: int) -> Op:
        td = self._array_arg(d, "ARRSUBSET")
        ts = self._array_arg(s, "ARRSUBSET")
        idx = self._int_reader(i, "ARRSUBSET")
        length = None if n == NOT_A_DS_ID else self._int_reader(n, "ARRSUBSET")
        m = self.mem

        def f() -> int:
            src = m[s]
            k = idx() & M32
            if k > len(src):
                part = src[:0]
            else:
                cnt = len(src) - k
                if length is not None:
                    cnt = min(cnt, length() & M32)
                part = src[k:k + cnt]
            try:
                new = poly.convert(td, ts, part)
            except poly.PolyError as exc:
                raise Fault(f"ARRSUBSET: {exc}") from None
            self._account(d, new)
            m[d] = new
            return nxt
        return f

    def _arrbuild(self, d: int, srcs: tuple[int, ...], nxt: int) -> Op:
        td = self._array_arg(d, "ARRBUILD")
        te = td.elem
        assert te is not None
        parts = []
        for s in srcs:
            self._arg(s, "ARRBUILD")
            ts = self.types[s]
            # a source of the destination's type is an array to append, anything else
            # one element (converted like a move: NBC passes constants of any size)
            parts.append((_same_type(td, ts), self._getter(s), ts))
        m = self.mem

        def f() -> int:
            out: list[Any] = []
            try:
                for whole, get, ts in parts:
                    if whole:
                        out.extend(copy_value(ts, get()))
                    else:
                        out.append(poly.convert(te, ts, copy_value(ts, get())))
            except poly.PolyError as exc:
                raise Fault(f"ARRBUILD: {exc}") from None
            new = bytearray(out) if td.string else out
            self._account(d, new)
            m[d] = new
            return nxt
        return f


def _same_type(a: DType, b: DType) -> bool:
    """``cCmdCompareDSType``."""
    if a.tc != b.tc:
        return False
    if a.tc == TC.CLUSTER:
        return len(a.members) == len(b.members) and all(
            _same_type(x, y) for x, y in zip(a.members, b.members))
    if a.tc == TC.ARRAY:
        assert a.elem is not None and b.elem is not None
        return _same_type(a.elem, b.elem)
    return True
