"""Serve a :class:`~nxt_link.emulator.BrickEmulator` on a pseudo-terminal.

Clients open the published path exactly like ``/dev/rfcomm0``: pyserial, or
nxt-python's device-file backend (which needs a real tty). Details that matter
(protocol doc §8):

* the slave side is put in raw mode at once and kept open by the server, so
  its settings survive clients coming and going and the master never sees EIO
  when a client closes;
* every reply frame is written with one ``write()`` (nxt-python reads the
  2-byte header and the body with single reads and does not loop);
* the published path is a symlink to the current pty; a simulated disconnect
  closes the pty (the client's next read or write fails with EIO), creates a
  fresh one and re-points the symlink, so a client reconnects by reopening the
  same path, as with a bound ``/dev/rfcommN``;
* simulated time runs at ``time_scale`` times real time (tests run the brick
  10-20x faster); link latency, if modelled, is in simulated time too.

One daemon thread per server; the emulator is touched only from that thread.
"""
from __future__ import annotations

import errno
import logging
import os
import select
import tempfile
import threading
import time
import tty

from nxt_link.emulator import BrickEmulator

__all__ = ["PtyBrickServer"]

log = logging.getLogger(__name__)

_IDLE_WAIT_S = 0.02


class PtyBrickServer:
    """Runs one emulated brick behind a pty until :meth:`stop`.

    Args:
        emulator: the brick.
        link_path: where to publish the symlink; default: a fresh private
            temporary directory (removed at stop).
        time_scale: simulated milliseconds per real millisecond.
    """

    def __init__(self, emulator: BrickEmulator, *, link_path: str | None = None,
                 time_scale: float = 1.0) -> None:
        if time_scale <= 0:
            raise ValueError("time scale must be > 0")
        self.emulator = emulator
        self.time_scale = time_scale
        self._own_dir: str | None = None
        if link_path is None:
            self._own_dir = tempfile.mkdtemp(prefix=f"cplus-brick-{emulator.config.name}-")
            link_path = os.path.join(self._own_dir, "tty")
        self.path = os.path.abspath(link_path)
        self._master = -1
        self._slave = -1
        self.tty_name = ""
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._wake_r, self._wake_w = os.pipe()
        self._lock = threading.Lock()
        self.error: BaseException | None = None
        self.cpu_s = 0.0  # thread CPU time spent serving (for the bench)

    # -- pty ------------------------------------------------------------------

    def _open_pty(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self.tty_name = os.ttyname(slave)
        tmp = f"{self.path}.{os.getpid()}.tmp"
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        os.symlink(self.tty_name, tmp)
        os.replace(tmp, self.path)
        log.info("%s: serving on %s -> %s", self.emulator.config.name, self.path, self.tty_name)

    def _close_pty(self) -> None:
        for fd in (self._master, self._slave):
            if fd >= 0:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = -1

    # -- lifecycle ----------------------------------------------------------------

    def start(self) -> str:
        """Create the pty, publish the path, start serving; return the path."""
        self._open_pty()
        self._thread = threading.Thread(target=self._run, name=f"brick-{self.emulator.config.name}",
                                        daemon=True)
        self._thread.start()
        return self.path

    def stop(self) -> None:
        """Stop serving, close the pty, remove the symlink (and our temp dir)."""
        self._stop.set()
        try:
            os.write(self._wake_w, b"x")
        except OSError:
            pass
        if self._thread is not None:
            self._thread.join(timeout=5)
        self._close_pty()
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass
        try:                  # only our own link: never a file someone put there since
            if os.path.islink(self.path) and os.readlink(self.path) == self.tty_name:
                os.unlink(self.path)
        except OSError:
            pass
        if self._own_dir is not None:
            try:
                os.rmdir(self._own_dir)
            except OSError:
                pass

    def __enter__(self) -> PtyBrickServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- the serving loop -------------------------------------------------------------

    def _run(self) -> None:
        cpu0 = time.thread_time()
        try:
            self._serve()
        except BaseException as exc:  # surfaced through .error and the log
            self.error = exc
            log.exception("brick %s: emulator failed", self.emulator.config.name)
        finally:
            self.cpu_s = time.thread_time() - cpu0

    def _sim_ms(self, wall0: float) -> float:
        return (time.monotonic() - wall0) * 1000.0 * self.time_scale

    def _serve(self) -> None:
        emu = self.emulator
        wall0 = time.monotonic() - emu.now_ms / 1000.0 / self.time_scale
        epoch = emu.link_epoch
        cpu0 = time.thread_time()
        while not self._stop.is_set():
            now = self._sim_ms(wall0)
            emu.advance_to(now)
            if emu.link_epoch != epoch:
                self._close_pty()
                self._open_pty()
                emu.restore_link()
                epoch = emu.link_epoch
            for data in emu.take_output(now):
                self._write(data)
            nxt = emu.next_event_ms()
            wait = _IDLE_WAIT_S
            if nxt is not None:
                wait = min(wait, max(0.0, (nxt - now) / 1000.0 / self.time_scale))
            try:
                ready, _, _ = select.select([self._master, self._wake_r], [], [], wait)
            except (OSError, ValueError):
                if self._stop.is_set():
                    break
                raise
            if self._master in ready:
                try:
                    data = os.read(self._master, 4096)
                except BlockingIOError:
                    data = b""
                except OSError as exc:
                    if exc.errno != errno.EIO:
                        raise
                    data = b""
                if data:
                    emu.receive(data, self._sim_ms(wall0))
            self.cpu_s = time.thread_time() - cpu0

    def _write(self, data: bytes) -> None:
        try:
            n = os.write(self._master, data)
        except BlockingIOError:
            n = 0
        except OSError as exc:
            log.debug("write to pty failed: %s", exc)
            return
        if n < len(data):
            # nobody is reading and the tty buffer is full: like a radio with no
            # listener, the rest of the frame is lost
            log.debug("%s: pty full, %d byte(s) lost", self.emulator.config.name, len(data) - n)
