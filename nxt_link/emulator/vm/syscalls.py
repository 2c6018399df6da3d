"""The system calls (``OP_SYSCALL``) the emulated brick supports.

Each takes the members of its argument cluster in the firmware's order
(``cCmdWrap*`` in ``c_cmd.c``; NBC's ``TLocation``, ``TDrawText``, ...
structures) and writes its results back into them. Supported: files (0-8),
sound (9-12), display text and shapes (13-17, 19), buttons (20), random numbers
(24), start tick (25), mailboxes (26, 27), Bluetooth status (28), keep-alive
(31), motor semaphores (40, 41), sleep timeout (46) and file listing (47).
Any other (I2C sensors, raw Bluetooth, IO map access, pictures, datalogs,
color sensors) is refused by the interpreter with an error naming it, never
skipped.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from nxt_link.emulator.vm.flash import HANDLEALREADYCLOSED
from nxt_link.emulator.vm.opcodes import TC
from nxt_link.emulator.vm.values import int_of, store

if TYPE_CHECKING:
    from nxt_link.emulator.vm.core import VMCore as VM
    from nxt_link.emulator.vm.flash import Flash

__all__ = ["SYSCALLS", "Syscall", "SyscallError"]

NO_ERR = 0
ERR_INVALID_PORT = -16
ERR_COMM_CHAN_NOT_READY = -32
ERR_COMM_CHAN_INVALID = -33


class SyscallError(Exception):
    """A system call the firmware would abort the program for."""


@dataclass(frozen=True)
class Syscall:
    """One system call: its implementation, its argument count, and whether it only
    reads (changes nothing outside the program's memory: a poll, see
    :mod:`nxt_link.emulator.vm.spin`)."""

    fn: Callable[[VM, list[int]], None]
    arity: int
    reads_only: bool = False


def _put(vm: VM, i: int, v: Any) -> None:
    t = vm.types[i]
    if t.tc == TC.ARRAY and not isinstance(v, int):  # a buffer or a name into an array
        vm.set(i, v)
    elif t.is_scalar:
        vm.mem[i] = store(t.tc, v)
    else:
        raise SyscallError(f"argument {i} is a {t.name}, a scalar is needed")


def _int(vm: VM, i: int) -> int:
    t = vm.types[i]
    if not t.is_scalar:
        raise SyscallError(f"argument {i} is a {t.name}, a scalar is needed")
    return int_of(t.tc, vm.mem[i])


def _text(vm: VM, i: int) -> bytes:
    t = vm.types[i]
    if not t.string:
        raise SyscallError(f"argument {i} is a {t.name}, a string is needed")
    data = bytes(vm.mem[i])
    nul = data.find(b"\0")
    return data if nul < 0 else data[:nul]


def _name(vm: VM, i: int) -> str:
    return _text(vm, i).decode("latin-1")


def _point(vm: VM, i: int) -> tuple[int, int]:
    t = vm.types[i]
    if t.tc != TC.CLUSTER or len(t.members) < 2:
        raise SyscallError(f"argument {i} is a {t.name}, a location {{x, y}} is needed")
    return _int(vm, t.members[0].index), _int(vm, t.members[1].index)


def _flash(vm: VM) -> Flash:
    return vm.io.flash  # type: ignore[return-value]


def _status_word(err: int) -> int:
    return err << 8


# -- files ----------------------------------------------------------------------------


def _file_open_read(vm: VM, a: list[int]) -> None:
    err, handle, size = _flash(vm).open_read(_name(vm, a[2]))
    _put(vm, a[0], _status_word(err))
    _put(vm, a[1], handle)
    if err == 0:
        _put(vm, a[3], size)


def _file_open_write(vm: VM, a: list[int]) -> None:
    err, handle = _flash(vm).open_write(_name(vm, a[2]), _int(vm, a[3]) & 0xFFFFFFFF,
                                        data_file=True)
    _put(vm, a[0], _status_word(err))
    _put(vm, a[1], handle)


def _file_open_append(vm: VM, a: list[int]) -> None:
    err, handle, room = _flash(vm).open_append(_name(vm, a[2]))
    _put(vm, a[0], _status_word(err))
    _put(vm, a[1], handle)
    _put(vm, a[3], room)


def _file_read(vm: VM, a: list[int]) -> None:
    want = _int(vm, a[3]) & 0xFFFFFFFF
    err, handle, data = _flash(vm).read(_int(vm, a[1]), want)
    buf = bytearray(want + 1)  # the firmware sizes the buffer first, then NUL-terminates
    buf[:len(data)] = data
    _put(vm, a[2], buf)
    _put(vm, a[3], len(data))
    _put(vm, a[0], _status_word(err))
    _put(vm, a[1], handle)


def _file_write(vm: VM, a: list[int]) -> None:
    t = vm.types[a[2]]
    if t.tc != TC.ARRAY:
        raise SyscallError(f"argument {a[2]} is a {t.name}, a buffer is needed")
    data = bytes(vm.mem[a[2]]) if t.string else bytes(v & 0xFF for v in vm.mem[a[2]])
    err, handle, n = _flash(vm).write(_int(vm, a[1]), data)
    _put(vm, a[0], _status_word(err))
    _put(vm, a[1], handle)
    _put(vm, a[3], n)


def _file_close(vm: VM, a: list[int]) -> None:
    handle = _int(vm, a[1]) & 0xFF
    if handle >= 16:
        _put(vm, a[0], _status_word(0x93))
        return
    err, _ = _flash(vm).close(handle)
    _put(vm, a[0], _status_word(err))


def _file_resolve_handle(vm: VM, a: list[int]) -> None:
    name = _name(vm, a[3]).lower()
    flash = _flash(vm)
    for i, h in enumerate(flash.handles):
        if h is not None and h.mode in ("read", "write") and h.file is not None \
                and h.file.name.lower() == name:
            _put(vm, a[1], i)
            _put(vm, a[2], 1 if h.mode == "write" else 0)
            _put(vm, a[0], 0)
            return
    _put(vm, a[1], 0xFF)
    _put(vm, a[0], _status_word(HANDLEALREADYCLOSED))


def _file_rename(vm: VM, a: list[int]) -> None:
    _put(vm, a[0], _status_word(_flash(vm).rename(_name(vm, a[1]), _name(vm, a[2]))))


def _file_delete(vm: VM, a: list[int]) -> None:
    _put(vm, a[0], _status_word(_flash(vm).delete(_name(vm, a[1]))))


def _list_files(vm: VM, a: list[int]) -> None:
    flash = _flash(vm)
    status, handle, name, _ = flash.find_first(_name(vm, a[1]))
    names = []
    if status == 0:
        while status == 0:
            names.append(name)
            status, _, name, _ = flash.find_next(handle)
        flash.close(handle)
        status = 0
    t = vm.types[a[2]]
    if t.tc != TC.ARRAY or t.elem is None or not t.elem.string:
        raise SyscallError(f"argument {a[2]} is a {t.name}, an array of strings is needed")
    vm.set(a[2], [bytearray(n.encode("latin-1") + b"\0") for n in names])
    _put(vm, a[0], -1 if not names else 0)


# -- sound, display, buttons ------------------------------------------------------------------


def _sound_play_file(vm: VM, a: list[int]) -> None:
    vm.io.play_file(_name(vm, a[1]), bool(_int(vm, a[2])), min(4, _int(vm, a[3]) & 0xFF))
    _put(vm, a[0], NO_ERR)


def _sound_play_tone(vm: VM, a: list[int]) -> None:
    vm.io.play_tone(_int(vm, a[1]) & 0xFFFF, _int(vm, a[2]) & 0xFFFF, bool(_int(vm, a[3])),
                    min(4, _int(vm, a[4]) & 0xFF))
    _put(vm, a[0], NO_ERR)


def _sound_get_state(vm: VM, a: list[int]) -> None:
    state, flags = vm.io.sound_state()
    _put(vm, a[0], state)
    _put(vm, a[1], flags)


def _sound_set_state(vm: VM, a: list[int]) -> None:
    vm.io.set_sound_state(_int(vm, a[1]) & 0xFF, _int(vm, a[2]) & 0xFF)
    _put(vm, a[0], vm.io.sound_state()[0])


def _draw_text(vm: VM, a: list[int]) -> None:
    x, y = _point(vm, a[1])
    vm.io.clear_screen_if_needed(_int(vm, a[3]))
    vm.io.draw_text(x & 0xFF, y & 0xFF, _text(vm, a[2]), _int(vm, a[3]))
    _put(vm, a[0], NO_ERR)


def _draw_shape(vm: VM, a: list[int]) -> None:
    # points, lines, circles and rectangles are drawn on a pixel display the
    # emulator does not keep; the screen is still cleared as the options ask
    vm.io.clear_screen_if_needed(_int(vm, a[-1]))
    _put(vm, a[0], NO_ERR)


def _set_screen_mode(vm: VM, a: list[int]) -> None:
    if _int(vm, a[1]) == 0:  # RESTORE_NXT_SCREEN
        vm.io.clear_screen_if_needed(1)
    _put(vm, a[0], NO_ERR)


def _read_button(vm: VM, a: list[int]) -> None:
    status, pressed, count = vm.io.read_button(_int(vm, a[1]) & 0xFF, bool(_int(vm, a[4])))
    _put(vm, a[0], status)
    _put(vm, a[2], 1 if pressed else 0)
    _put(vm, a[3], count)


# -- misc ---------------------------------------------------------------------------------


def _random(vm: VM, a: list[int]) -> None:
    _put(vm, a[0], vm.io.random())


def _start_tick(vm: VM, a: list[int]) -> None:
    _put(vm, a[0], vm.start_tick)


def _message_write(vm: VM, a: list[int]) -> None:
    data = bytes(vm.mem[a[2]]) if vm.types[a[2]].string else b""
    _put(vm, a[0], vm.io.message_write(_int(vm, a[1]) & 0xFF, data))


def _message_read(vm: VM, a: list[int]) -> None:
    remove = bool(_int(vm, a[2]))
    status, data = vm.io.message_read(_int(vm, a[1]) & 0xFF, remove)
    if status == 0 and remove:
        vm.io_epoch += 1  # a message left the mailbox: not a mere poll
    if not vm.types[a[3]].string:
        raise SyscallError(f"argument {a[3]} is a {vm.types[a[3]].name}, a string is needed")
    vm.set(a[3], bytearray(data) if status == 0 and data else bytearray(b"\0"))
    _put(vm, a[0], status)


def _bt_check_status(vm: VM, a: list[int]) -> None:
    conn = _int(vm, a[1]) & 0xFF
    if conn > 3:
        status = ERR_COMM_CHAN_INVALID
    else:
        status = vm.io.bluetooth_status(conn)  # type: ignore[attr-defined]
    _put(vm, a[0], status)


def _keep_alive(vm: VM, a: list[int]) -> None:
    _put(vm, a[0], vm.io.keep_alive())


def _read_sem(vm: VM, a: list[int]) -> None:
    sem = vm.io.semaphores  # type: ignore[attr-defined]
    _put(vm, a[0], sem[1] if _int(vm, a[1]) else sem[0])


def _write_sem(vm: VM, a: list[int]) -> None:
    sem = vm.io.semaphores  # type: ignore[attr-defined]
    k = 1 if _int(vm, a[1]) else 0
    new, clear = _int(vm, a[2]) & 0xFF, bool(_int(vm, a[3]))
    sem[k] = (sem[k] & ~new if clear else sem[k] | new) & 0xFF
    _put(vm, a[0], sem[k])


def _set_sleep_timeout(vm: VM, a: list[int]) -> None:
    vm.io.set_sleep_timeout(_int(vm, a[1]) & 0xFFFFFFFF)  # type: ignore[attr-defined]
    _put(vm, a[0], NO_ERR)


SYSCALLS: dict[int, Syscall] = {
    0: Syscall(_file_open_read, 4),
    1: Syscall(_file_open_write, 4),
    2: Syscall(_file_open_append, 4),
    3: Syscall(_file_read, 4),
    4: Syscall(_file_write, 4),
    5: Syscall(_file_close, 2),
    6: Syscall(_file_resolve_handle, 4),
    7: Syscall(_file_rename, 3),
    8: Syscall(_file_delete, 2),
    9: Syscall(_sound_play_file, 4),
    10: Syscall(_sound_play_tone, 5),
    11: Syscall(_sound_get_state, 2, reads_only=True),
    12: Syscall(_sound_set_state, 3),
    13: Syscall(_draw_text, 4),
    14: Syscall(_draw_shape, 3),
    15: Syscall(_draw_shape, 4),
    16: Syscall(_draw_shape, 4),
    17: Syscall(_draw_shape, 4),
    19: Syscall(_set_screen_mode, 2),
    20: Syscall(_read_button, 5, reads_only=True),
    24: Syscall(_random, 1),
    25: Syscall(_start_tick, 1, reads_only=True),
    26: Syscall(_message_write, 3),
    27: Syscall(_message_read, 4, reads_only=True),
    28: Syscall(_bt_check_status, 2, reads_only=True),
    31: Syscall(_keep_alive, 1, reads_only=True),
    40: Syscall(_read_sem, 2, reads_only=True),
    41: Syscall(_write_sem, 4),
    46: Syscall(_set_sleep_timeout, 2),
    47: Syscall(_list_files, 3),
}
