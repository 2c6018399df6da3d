"""Strings and conversions: ``strcat``, ``strsubset``, ``strtobytearr``, ``bytearrtostr``,
``numtostring``, ``stringtonum``, ``flatten``, ``unflatten``.

Strings are ``bytearray`` values with their NUL; every result is a new value
accounted in the pool. ``numtostring`` formats floats as the firmware does
(``%.2f`` without trailing zeros, ``%.6g`` when wide), ``stringtonum`` reads
the longest number at the offset (``strtod``) and where it ends.
"""
from __future__ import annotations

import math
import re

from nxt_link.emulator.vm import poly
from nxt_link.emulator.vm.core import NOT_A_DS_ID, Fault, Op, VMCore
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.values import M32, SIGNED, copy_value, flat_size, flatten, store, to_f32, unflatten

__all__ = ["StringOps"]

_FLOAT_RE = re.compile(rb"\s*([+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf(?:inity)?|nan))",
                       re.IGNORECASE)


class StringOps(VMCore):
    """Compilers of the string and conversion instructions."""

    def _strcat(self, d: int, srcs: tuple[int, ...], nxt: int) -> Op:
        self._array_arg(d, "STRCAT", string=True)
        for s in srcs:
            self._array_arg(s, "STRCAT", string=True)
        m = self.mem

        def f() -> int:
            out = bytearray()
            for s in srcs:
                v = m[s]
                out += v[:-1] if v else v
            out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _strsubset(self, d: int, s: int, i: int, n: int, nxt: int) -> Op:
        self._array_arg(d, "STRSUBSET", string=True)
        self._array_arg(s, "STRSUBSET", string=True)
        idx = self._int_reader(i, "STRSUBSET")
        length = None if n == NOT_A_DS_ID else self._int_reader(n, "STRSUBSET")
        m = self.mem

        def f() -> int:
            src = m[s]
            count = max(0, len(src) - 1)
            k = idx() & M32
            if k > count:
                out = bytearray(b"\0")
            else:
                cnt = count - k
                if length is not None:
                    cnt = min(cnt, length() & M32)
                out = bytearray(src[k:k + cnt])
                out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _strtobytearr(self, d: int, s: int, nxt: int) -> Op:
        self._array_arg(d, "STRTOBYTEARR", string=True)
        self._array_arg(s, "STRTOBYTEARR", string=True)
        m = self.mem

        def f() -> int:
            src = m[s]
            if src:
                out = bytearray(src[:-1])
                self._account(d, out)
                m[d] = out
            return nxt
        return f

    def _bytearrtostr(self, d: int, s: int, nxt: int) -> Op:
        self._array_arg(d, "BYTEARRTOSTR", string=True)
        self._array_arg(s, "BYTEARRTOSTR", string=True)
        m = self.mem

        def f() -> int:
            out = bytearray(m[s])
            out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _numtostring(self, d: int, s: int, nxt: int) -> Op:
        self._array_arg(d, "NUMTOSTRING", string=True)
        self._scalar_arg(s, "NUMTOSTRING")
        m = self.mem
        ts = self.types[s].tc

        def f() -> int:
            v = m[s]
            if ts == TC.FLOAT:
                text = _format_float(v)
            elif ts in SIGNED:
                text = str(v)
            else:
                text = str(v & M32)
            out = bytearray(text.encode("ascii"))
            out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _stringtonum(self, d: int, past: int, s: int, off: int, dflt: int, nxt: int) -> Op:
        self._scalar_arg(d, "STRINGTONUM")
        self._scalar_arg(past, "STRINGTONUM")
        self._array_arg(s, "STRINGTONUM", string=True)
        offset = self._int_reader(off, "STRINGTONUM")
        default = self._int_reader(dflt, "STRINGTONUM")
        m = self.mem
        td, tp = self.types[d].tc, self.types[past].tc

        def f() -> int:
            text = bytes(m[s])
            nul = text.find(b"\0")
            if nul >= 0:
                text = text[:nul]
            k = offset() & M32
            match = _FLOAT_RE.match(text, k) if k <= len(text) else None
            if match:
                value = to_f32(float(match.group(1)))
                i = k
                while i < len(text) and not 0x30 <= text[i] <= 0x39:
                    i += 1
                dot = False
                while i < len(text):
                    ch = text[i]
                    if 0x30 <= ch <= 0x39:
                        i += 1
                    elif ch == 0x2E and not dot:
                        dot = True
                        i += 1
                    else:
                        break
                end = i
            else:
                value = to_f32(float(default()))
                end = 0
            m[d] = store(td, value)
            m[past] = store(tp, end)
            return nxt
        return f

    def _flatten(self, d: int, s: int, nxt: int) -> Op:
        self._array_arg(d, "FLATTEN", string=True)
        self._arg(s, "FLATTEN")
        ts = self.types[s]
        get_s = self._getter(s)
        m = self.mem

        def f() -> int:
            out = bytearray()
            flatten(ts, get_s(), out)
            out.append(0)
            self._account(d, out)
            m[d] = out
            return nxt
        return f

    def _unflatten(self, d: int, err: int, s: int, tmpl: int, nxt: int) -> Op:
        self._arg(d, "UNFLATTEN")
        self._scalar_arg(err, "UNFLATTEN")
        self._array_arg(s, "UNFLATTEN", string=True)
        self._arg(tmpl, "UNFLATTEN")
        td, tt = self.types[d], self.types[tmpl]
        get_t, set_d = self._getter(tmpl), self._setter(d)
        m = self.mem
        et = self.types[err].tc

        def f() -> int:
            template = get_t()
            try:
                value = poly.convert(td, tt, copy_value(tt, template))
            except poly.PolyError as exc:
                raise Fault(f"UNFLATTEN: {exc}") from None
            data = bytes(m[s])
            n = max(0, len(data) - 1)
            if n == flat_size(td, value):
                value, _ = unflatten(td, value, data, 0)
                m[err] = store(et, 0)
            else:
                m[err] = store(et, 1)
            set_d(value)
            return nxt
        return f


def _format_float(v: float) -> str:
    """``OP_NUMTOSTRING`` of a float: ``%.2f`` without trailing zeros, ``%.6g`` when wide."""
    if math.isnan(v) or math.isinf(v) or v > 9999999999999.99 or v < -999999999999.99:
        return _c_format("g", v)
    text = f"{v:.2f}"
    if text.endswith("0"):
        text = f"{v:.0f}" if text.endswith("00") else f"{v:.1f}"
    return text


def _c_format(kind: str, v: float) -> str:
    """C's ``%.6g`` (``inf``/``nan`` spelled as C does)."""
    if math.isnan(v):
        return "nan" if math.copysign(1.0, v) > 0 else "-nan"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return f"{v:.6g}"
