"""Opcode, condition-code, type-code and system-call numbers of the NXT VM.

Numbers and names as in the "LEGO MINDSTORMS NXT Executable File Specification"
(v2.0, firmware 1.28) and the firmware's ``c_cmd_bytecodes.h``; the names are
used in error messages and in :func:`nxt_link.emulator.vm.disassemble`.
"""
from __future__ import annotations

__all__ = ["OPCODE_NAMES", "SHORT_OPCODE_NAMES", "SYSCALL_NAMES", "CC_NAMES", "TC"]

OPCODE_NAMES: dict[int, str] = {
    0x00: "ADD", 0x01: "SUB", 0x02: "NEG", 0x03: "MUL", 0x04: "DIV", 0x05: "MOD",
    0x06: "AND", 0x07: "OR", 0x08: "XOR", 0x09: "NOT",
    0x0A: "CMNT", 0x0B: "LSL", 0x0C: "LSR", 0x0D: "ASL", 0x0E: "ASR", 0x0F: "ROTL",
    0x10: "ROTR",
    0x11: "CMP", 0x12: "TST", 0x13: "CMPSET", 0x14: "TSTSET",
    0x15: "INDEX", 0x16: "REPLACE", 0x17: "ARRSIZE", 0x18: "ARRBUILD", 0x19: "ARRSUBSET",
    0x1A: "ARRINIT",
    0x1B: "MOV", 0x1C: "SET",
    0x1D: "FLATTEN", 0x1E: "UNFLATTEN", 0x1F: "NUMTOSTRING", 0x20: "STRINGTONUM",
    0x21: "STRCAT", 0x22: "STRSUBSET", 0x23: "STRTOBYTEARR", 0x24: "BYTEARRTOSTR",
    0x25: "JMP", 0x26: "BRCMP", 0x27: "BRTST", 0x28: "SYSCALL", 0x29: "STOP",
    0x2A: "FINCLUMP", 0x2B: "FINCLUMPIMMED", 0x2C: "ACQUIRE", 0x2D: "RELEASE",
    0x2E: "SUBCALL", 0x2F: "SUBRET",
    0x30: "SETIN", 0x31: "SETOUT", 0x32: "GETIN", 0x33: "GETOUT",
    0x34: "WAIT", 0x35: "GETTICK",
    0x36: "SQRT", 0x37: "ABS",
}

SHORT_OPCODE_NAMES: dict[int, str] = {0: "MOV", 1: "ACQUIRE", 2: "RELEASE", 3: "SUBCALL"}

CC_NAMES = {0: "LT", 1: "GT", 2: "LTEQ", 3: "GTEQ", 4: "EQ", 5: "NEQ"}

SYSCALL_NAMES: dict[int, str] = {
    0: "FileOpenRead", 1: "FileOpenWrite", 2: "FileOpenAppend", 3: "FileRead",
    4: "FileWrite", 5: "FileClose", 6: "FileResolveHandle", 7: "FileRename",
    8: "FileDelete", 9: "SoundPlayFile", 10: "SoundPlayTone", 11: "SoundGetState",
    12: "SoundSetState", 13: "DrawText", 14: "DrawPoint", 15: "DrawLine", 16: "DrawCircle",
    17: "DrawRect", 18: "DrawPicture", 19: "SetScreenMode", 20: "ReadButton",
    21: "CommLSWrite", 22: "CommLSRead", 23: "CommLSCheckStatus", 24: "RandomNumber",
    25: "GetStartTick", 26: "MessageWrite", 27: "MessageRead", 28: "CommBTCheckStatus",
    29: "CommBTWrite", 30: "CommBTRead", 31: "KeepAlive", 32: "IOMapRead", 33: "IOMapWrite",
    34: "ColorSensorRead", 35: "CommBTOnOff", 36: "CommBTConnection", 37: "CommHSWrite",
    38: "CommHSRead", 39: "CommHSCheckStatus", 40: "ReadSemData", 41: "WriteSemData",
    42: "ComputeCalibValue", 43: "UpdateCalibCacheInfo", 44: "DatalogWrite",
    45: "DatalogGetTimes", 46: "SetSleepTimeout", 47: "ListFiles",
}


class TC:
    """Dataspace type codes (DSTOC entries)."""

    VOID = 0
    UBYTE = 1
    SBYTE = 2
    UWORD = 3
    SWORD = 4
    ULONG = 5
    SLONG = 6
    ARRAY = 7
    CLUSTER = 8
    MUTEX = 9
    FLOAT = 10

    NAMES = {0: "void", 1: "ubyte", 2: "sbyte", 3: "uword", 4: "sword", 5: "ulong",
             6: "slong", 7: "array", 8: "cluster", 9: "mutex", 10: "float"}
    #: bytes a value of the type takes in the dataspace (an array: its dope-vector index)
    SIZE = {0: 0, 1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 2, 8: 0, 9: 4, 10: 4}
