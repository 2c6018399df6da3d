"""Serve a :class:`~nxt_link.emulator.emulator.BrickEmulator` on a pseudo-terminal.

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
  10-20x faster); link latency, if modelled, is in simulated time too;
* or, given a :class:`~nxt_link.wire.clock.SimClock`, on simulated time shared with the PC side
  in the same process: the server's thread is a participant of that clock, waits on it for
  its next link event or for bytes (counted on the clock's :class:`~nxt_link.wire.clock.Channel`
  of the pty), and the brick runs exactly as far as the clock has moved. Nothing then
  depends on real time, so a slow or loaded machine changes how long a run takes, not what
  happens in it.

One daemon thread per server; the emulator is touched only from that thread.
"""
from __future__ import annotations

import errno
import logging
import math
import os
import select
import tempfile
import threading
import time
import tty

from nxt_link.emulator.emulator import BrickEmulator
from nxt_link.wire.clock import READABLE, STOPPED, TIME, Channel, SimClock, start_thread

__all__ = ["PtyBrickServer"]

log = logging.getLogger(__name__)

_IDLE_WAIT_S = 0.02
#: Simulated milliseconds the brick runs (real time) before the server looks at the pty and
#: at :meth:`PtyBrickServer.stop` again: each costs at most one bounded time slice of the
#: program (:data:`nxt_link.emulator.vm.scheduler.MAX_OVERRUN`), a few milliseconds of real time.
MAX_ADVANCE_MS = 20
#: How far (real seconds) the brick may fall behind real time before its clock slips
#: (:attr:`PtyBrickServer.slipped_ms`): a moment of load is caught up, a program the
#: interpreter runs slower than real time does not pile up work without end.
MAX_LAG_S = 0.25
#: Real time within which counted bytes must show up on the pty (they are already written;
#: only the kernel's flip buffer delays them): a safety net, far longer than it takes.
ARRIVAL_S = 5.0


class PtyBrickServer:
    """Runs one emulated brick behind a pty until :meth:`stop`.

    Args:
        emulator: the brick.
        link_path: where to publish the symlink; default: a fresh private
            temporary directory (removed at stop).
        time_scale: simulated milliseconds per real millisecond (wall-clock mode).
        clock: a :class:`~nxt_link.wire.clock.SimClock`: run on it instead of real time (then
            ``time_scale`` must stay 1, and the clients must use the same clock).
    """

    def __init__(self, emulator: BrickEmulator, *, link_path: str | None = None,
                 time_scale: float = 1.0, clock: SimClock | None = None) -> None:
        if time_scale <= 0:
            raise ValueError("time scale must be > 0")
        if clock is not None and time_scale != 1:
            raise ValueError("a brick on simulated time has no time scale")
        self.emulator = emulator
        self.time_scale = time_scale
        self.clock = clock
        self.channel: Channel | None = None
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
        self.slipped_ms = 0.0
        """Simulated time skipped because the brick could not keep up with real time."""

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
        if self.clock is not None:
            self.channel = self.clock.open_channel(self.tty_name)
        os.symlink(self.tty_name, tmp)
        os.replace(tmp, self.path)
        log.info("%s: serving on %s -> %s", self.emulator.config.name, self.path, self.tty_name)

    def _close_fds(self) -> None:
        """Close both ends of the pty (either may be closed already)."""
        for fd in (self._master, self._slave):
            if fd >= 0:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = -1

    def _close_pty(self) -> None:
        self._close_fds()
        if self.clock is not None and self.channel is not None:
            self.clock.close_channel(self.channel)
            self.channel = None

    def _reopen_pty(self) -> None:
        """A simulated disconnect: a fresh pty behind the same path. On simulated time the
        old channel closes only once the new path is published, so a client woken by the
        drop finds the new pty at once (whatever the threads' real timing)."""
        old = self.channel
        self.channel = None
        self._close_fds()
        self._open_pty()
        if self.clock is not None and old is not None:
            self.clock.close_channel(old)

    # -- lifecycle ----------------------------------------------------------------

    def start(self) -> str:
        """Create the pty, publish the path, start serving; return the path."""
        self._open_pty()
        name = f"brick-{self.emulator.config.name}"
        if self.clock is not None:
            self._thread = start_thread(self.clock, name, self._run)
        else:
            self._thread = threading.Thread(target=self._run, name=name, daemon=True)
            self._thread.start()
        return self.path

    def stop(self) -> None:
        """Stop serving, close the pty, remove the symlink (and our temp dir)."""
        self._stop.set()
        try:
            os.write(self._wake_w, b"x")
        except OSError:
            pass
        participant = getattr(self._thread, "_sim_participant", None)
        if self.clock is not None and participant is not None:
            self.clock.detach(participant)
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
            if self.clock is not None:
                self._serve_simulated(self.clock)
            else:
                self._serve()
        except BaseException as exc:  # surfaced through .error and the log
            self.error = exc
            log.exception("brick %s: emulator failed", self.emulator.config.name)
        finally:
            self.cpu_s = time.thread_time() - cpu0

    def _sim_ms(self, wall0: float) -> float:
        return (time.monotonic() - wall0) * 1000.0 * self.time_scale

    def _serve(self) -> None:
        """The serving loop on real time.  Each turn runs the brick at most
        :data:`MAX_ADVANCE_MS` simulated milliseconds (less when a reply is ready to go)
        before it looks at the pty and at :meth:`stop` again; bytes read while the brick is
        behind real time reach it at its next millisecond, as they did when it was always
        caught up before the pty was read; and a brick that cannot keep up (a program that
        spends every slice, run slower than the ARM7 would) lets its clock slip
        (:data:`MAX_LAG_S`) rather than fall further behind.  So a command is answered, and
        the server stops, within a bounded time whatever the program does."""
        emu = self.emulator
        wall0 = time.monotonic() - emu.now_ms / 1000.0 / self.time_scale
        epoch = emu.link_epoch
        cpu0 = time.thread_time()
        max_lag_ms = MAX_LAG_S * 1000.0 * self.time_scale
        while not self._stop.is_set():
            now = self._sim_ms(wall0)
            behind = now - emu.now_ms
            if behind > max_lag_ms:      # the slipped time is never run: real time moves on
                wall0 += (behind - max_lag_ms) / 1000.0 / self.time_scale
                self.slipped_ms += behind - max_lag_ms
                now = emu.now_ms + max_lag_ms
            emu.advance_to(min(now, emu.now_ms + MAX_ADVANCE_MS), until_reply=True)
            epoch = self._deliver(epoch, now)
            nxt = emu.next_event_ms()
            wait = _IDLE_WAIT_S
            lagging = emu.now_ms + 1 <= now
            if lagging:                  # behind: only a look at the pty and at stop()
                wait = 0.0
            elif nxt is not None:
                wait = min(wait, max(0.0, (nxt - now) / 1000.0 / self.time_scale))
            try:
                ready, _, _ = select.select([self._master, self._wake_r], [], [], wait)
            except (OSError, ValueError):
                if self._stop.is_set():
                    break
                raise
            if self._master in ready:
                data = self._read_master()
                if data:         # a brick behind real time gets them at its own next millisecond
                    emu.receive(data, emu.now_ms + 1 if lagging else self._sim_ms(wall0))
            self.cpu_s = time.thread_time() - cpu0

    def _serve_simulated(self, clock: SimClock) -> None:
        """The serving loop on simulated time: run the brick to the clock's time, deliver
        what is due, then wait on the clock for the next link event or for bytes."""
        emu = self.emulator
        t0 = clock.now() - emu.now_ms / 1000.0
        epoch = emu.link_epoch
        floor_ms = float(emu.now_ms)   # a deadline reached counts as reached, float noise aside
        cpu0 = time.thread_time()
        while not self._stop.is_set():
            now = max(floor_ms, (clock.now() - t0) * 1000.0)
            emu.advance_to(now)
            epoch = self._deliver(epoch, now)
            nxt = emu.next_event_ms()
            if nxt is not None and nxt <= now:
                nxt = math.floor(now) + 1.0   # due at the next firmware millisecond
            channel = self.channel
            assert channel is not None
            why = clock.wait_readable(channel.to_brick, None if nxt is None else t0 + nxt / 1000.0)
            self.cpu_s = time.thread_time() - cpu0
            if why == STOPPED:
                break
            if why == TIME and nxt is not None:
                floor_ms = max(floor_ms, nxt)
            elif why == READABLE:
                data = self._read_counted(clock, channel)
                if data:
                    emu.receive(data, max(floor_ms, (clock.now() - t0) * 1000.0))

    def _deliver(self, epoch: int, now: float) -> int:
        """After the brick ran to ``now``: a new pty if the link dropped since ``epoch`` (the
        emulator's link epoch, returned as it is now), then the bytes due to the PC written."""
        emu = self.emulator
        if emu.link_epoch != epoch:
            self._reopen_pty()
            emu.restore_link()
            epoch = emu.link_epoch
        for data in emu.take_output(now):
            self._write(data)
        return epoch

    def _read_counted(self, clock: SimClock, channel: Channel) -> bytes:
        """The bytes the clock counted on their way to the brick (already written: only the
        kernel may still hold them back for a moment)."""
        pipe = channel.to_brick
        if pipe.closed:
            return b""
        ready, _, _ = select.select([self._master], [], [], ARRIVAL_S)
        if not ready:
            log.warning("%s: %d counted byte(s) never arrived", self.emulator.config.name, pipe.pending)
            clock.lost(pipe)
            return b""
        data = self._read_master()
        clock.consumed(pipe, len(data))
        return data

    def _read_master(self) -> bytes:
        """What the pty's master side has for the brick: b"" when nothing is there yet, or
        when no slave is open (EIO, between a client's close and the next open)."""
        try:
            return os.read(self._master, 4096)
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno != errno.EIO:
                raise
            return b""

    def _write(self, data: bytes) -> None:
        pipe = None
        if self.clock is not None and self.channel is not None:
            pipe = self.channel.to_pc
            self.clock.wrote(pipe, len(data))
        try:
            n = os.write(self._master, data)
        except BlockingIOError:
            n = 0
        except OSError as exc:
            log.debug("write to pty failed: %s", exc)
            if pipe is not None:
                self.clock.consumed(pipe, len(data))  # type: ignore[union-attr]
            return
        if pipe is not None and n < len(data):
            self.clock.consumed(pipe, len(data) - n)  # type: ignore[union-attr]
        if n < len(data):
            # nobody is reading and the tty buffer is full: like a radio with no
            # listener, the rest of the frame is lost
            log.debug("%s: pty full, %d byte(s) lost", self.emulator.config.name, len(data) - n)
