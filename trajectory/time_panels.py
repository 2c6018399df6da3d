"""The panels over time under the execution picture: what a user tuning the bricks'
P-controller looks at.

Per brick, the motor angles (setpoint dashed, measured solid) and the tracking error
(measured - setpoint) against time; for all bricks, one row each with their phases
(connect, upload, homing, waiting for the start, run, log read), the interval in which each
started (the start skew between bricks), the other events the log holds (timeouts, damaged
replies, a lost link ...) and where the run stopped. Where a motor was not following (a
stall: its error beyond the online monitor's threshold) its error panel is shaded and named.
Every panel uses one clock (the PC's, or the simulated one of emulated bricks: the timeline's
``clock`` says which), so a late brick shows as a shifted curve. The legends say what each
motor drives (``A: carriage wheel``, ``C: arm``, from the scene): two wheels of one carriage
turn alike, so the first is drawn wide and the second narrow over it, and both show; the
setpoints are thin dark dashes over the measured curves.

The phases come from the brick's events; a time between two of them is ``waiting`` (the bricks
are uploaded and homed one after the other, so one waits while another is served):

>>> b = BrickTimeline("r1", ("A",), 0.1, [[0], [5]], [[0], [4]], start_s=(1.0, 1.02),
...                   events=[(0.2, "link ok", ""), (0.5, "upload verified", ""), (1.5, "log read", "")])
>>> [(p, round(a, 2), round(z, 2)) for p, a, z in _phases(b)]
[('connect', 0.0, 0.2), ('upload', 0.2, 0.5), ('waiting', 0.5, 1.01), ('run', 1.01, 1.21), ('log read', 1.21, 1.5)]
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.gridspec import SubplotSpec
from matplotlib.patches import Patch

from .timeline import MILESTONES, STALL_ERROR_DEG, BrickTimeline, RunTimeline

__all__ = ["add_time_panels", "MOTOR_COLORS"]

#: One colour per motor of a brick (the robot's own colour names the brick in the titles).
MOTOR_COLORS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e")
_PHASE_COLORS = {"connect": "0.82", "upload": "#c7b36a", "waiting": "white", "homing": "#2a9fd6",
                 "wait for start": "0.62", "run": None, "log read": "#d4c2e6"}
_MIN_BAR = 0.008
"""The narrowest phase bar, as a fraction of the panel's time span: a shorter phase (homing takes
a few hundredths of a second) is drawn that wide, and its legend entry gives its duration."""
_MAX_EVENT_LABELS = 6


def _first(brick: BrickTimeline, name: str) -> float | None:
    return next((t for t, e, _ in brick.events if e == name), None)


def _phases(brick: BrickTimeline) -> list[tuple[str, float, float]]:
    """``(phase, start, end)`` for every phase the events (and the start interval) delimit."""
    link, upload = _first(brick, "link ok"), _first(brick, "upload verified")
    homing, ready, sent = _first(brick, "homing"), _first(brick, "ready"), _first(brick, "start sent")
    read = _first(brick, "log read")
    out: list[tuple[str, float, float]] = []
    if link is not None:
        out.append(("connect", 0.0, link))
    if link is not None and upload is not None:
        out.append(("upload", link, upload))
    if homing is not None and ready is not None:
        out.append(("homing", homing, ready))
    start = brick.start_mid_s
    if sent is not None and brick.start_s is not None:
        out.append(("wait for start", sent, brick.start_s[0]))
    if start is not None:
        measured = np.flatnonzero(np.all(np.isfinite(brick.measured_deg), axis=1))
        end = float(brick.tick_end_s[measured[-1]]) if len(measured) else start
        out.append(("run", start, end))
        if read is not None and read > end:
            out.append(("log read", end, read))
    kept = sorted(((name, a, b) for name, a, b in out if b >= a), key=lambda p: p[1])
    gaps = [("waiting", p[2], q[1]) for p, q in zip(kept, kept[1:]) if q[1] - p[2] > 1e-6]
    return sorted(kept + gaps, key=lambda p: p[1])


def _mark_stop(axes: Sequence[Axes], timeline: RunTimeline) -> None:
    if timeline.stopped is not None:
        for ax in axes:
            ax.axvline(timeline.stopped[0], color="crimson", linewidth=1.2, linestyle="-", zorder=6)


_SAME_DEG = 1.0
"""Two motors whose measured angles never differ by more than this draw one curve."""


def _alike(brick: BrickTimeline) -> dict[int, int]:
    """For each motor whose measured curve is another's (within ``_SAME_DEG``), that earlier motor."""
    out: dict[int, int] = {}
    rows = brick.measured_deg
    known = np.all(np.isfinite(rows), axis=1)
    if not known.any():
        return out
    for k in range(rows.shape[1]):
        for j in range(k):
            if j not in out and np.abs(rows[known, k] - rows[known, j]).max() <= _SAME_DEG:
                out[k] = j
                break
    return out


def _headroom(ax: Axes, rows: int) -> None:
    """Raise the top of ``ax`` so that a legend of ``rows`` lines in its upper left corner lies
    above every curve (a legend over a curve hides the part of it a reader looks for)."""
    values = [v for line in ax.get_lines() for v in np.asarray(line.get_ydata(), dtype=float).ravel()
              if np.isfinite(v)]
    if not values:
        return
    lo, hi = min(values), max(values)
    lo -= 0.05 * max(hi - lo, 1.0)
    fig = ax.get_figure(root=True)
    assert isinstance(fig, Figure)
    # the axes' height before the layout shrinks it for titles and labels (a fifth, at most)
    axes_pt = ax.get_position().height * fig.get_size_inches()[1] * 72 * 0.8
    legend_pt = rows * 6.5 * 1.4 + 12
    f = min(0.75, legend_pt / max(axes_pt, 1.0))           # the part of the axes the legend takes
    ax.set_ylim(lo, max(hi + 1.0, (hi - f * lo) / (1 - f)))


def _motor_panels(ax_deg: Axes, ax_err: Axes, brick: BrickTimeline, color: str,
                  roles: Mapping[str, str] | None = None, clock: str = "PC clock") -> None:
    t = brick.tick_end_s
    err = brick.error_deg
    roles = roles or {}
    alike = _alike(brick)
    for j, port in enumerate(brick.ports):
        c = MOTOR_COLORS[j % len(MOTOR_COLORS)]
        under = any(j == first for first in alike.values())
        width = 4.2 if under else 1.6                    # a curve another motor's lies on is drawn wide
        what = [roles[port]] if port in roles else []
        if j in alike:
            what.append(f"over {brick.ports[alike[j]]}: the same curve")
        label = f"{port} ({', '.join(what)})" if what else port
        ax_deg.plot(t, brick.measured_deg[:, j], color=c, linewidth=width, label=label,
                    solid_capstyle="butt", zorder=2)
        ax_deg.plot(t, brick.setpoint_deg[:, j], color="0.1", linewidth=0.8, linestyle=(0, (3, 3)), zorder=3)
        e = err[:, j]
        known = e[np.isfinite(e)]
        stats = (f": max {np.abs(known).max():.0f}°, rms {np.sqrt((known ** 2).mean()):.2f}°" if len(known)
                 else ": not measured")
        role = f" ({roles[port]})" if port in roles else ""
        ax_err.plot(t, e, color=c, linewidth=3.4 if under else 1.2, zorder=2, label=f"{port}{role}{stats}")
    ax_deg.plot([], [], color="0.1", linewidth=0.8, linestyle=(0, (3, 3)), zorder=3, label="setpoints")
    ax_err.axhline(0.0, color="0.4", linewidth=0.7, zorder=1)
    spans = brick.stall_spans()
    for k, (port, a, z) in enumerate(spans):      # where a motor was not following: shaded, named
        ax_err.axvspan(a, z, color="crimson", alpha=0.12, zorder=0,
                       label=f"not following (|error| > {STALL_ERROR_DEG:.0f}°)" if k == 0 else None)
        ax_err.annotate(f"{port} not following", xy=(a, 1.0), xycoords=("data", "axes fraction"),
                        xytext=(3, -12), textcoords="offset points", fontsize=7, color="crimson",
                        bbox={"fc": "white", "ec": "none", "alpha": 0.8, "pad": 1})
    ax_deg.set_title(f"{brick.name}: motor angles (setpoint dashed, measured solid)", fontsize=9, color=color)
    ax_err.set_title(f"{brick.name}: tracking error (measured - setpoint)", fontsize=9, color=color)
    ax_deg.set_ylabel("degrees", fontsize=8)
    ax_err.set_ylabel("degrees", fontsize=8)
    ax_err.set_xlabel(f"time (s, {clock})", fontsize=8)
    if brick.start_mid_s is None:
        ax_deg.text(0.5, 0.5, f"{brick.name} never started (reached: {brick.reached})", transform=ax_deg.transAxes,
                    ha="center", va="center", fontsize=9, color="crimson")
    for ax in (ax_deg, ax_err):                 # the legend gets a band of its own above the curves
        legend = ax.legend(fontsize=6.5, loc="upper left", ncol=1, frameon=True, framealpha=0.85, edgecolor="none")
        _headroom(ax, len(legend.get_texts()))
    for ax in (ax_deg, ax_err):
        ax.tick_params(labelsize=7)
        ax.grid(True, linewidth=0.4, alpha=0.5)


def _skew_text(timeline: RunTimeline) -> str:
    if timeline.skew_s is None:
        return ""
    est, lo, hi = timeline.skew_s
    return f"; start skew {est * 1000:.0f} ms (between {lo * 1000:.0f} and {hi * 1000:.0f} ms)"


def _bricks_panel(ax: Axes, timeline: RunTimeline, colors: Sequence[str]) -> None:
    n = len(timeline.bricks)
    used: set[str] = set()
    short: dict[str, float] = {}          # phases drawn wider than they lasted: their longest duration
    lo_s, hi_s = timeline.span_s()
    least = _MIN_BAR * max(hi_s - lo_s, 1e-3)
    for row, (brick, color) in enumerate(zip(timeline.bricks, colors)):
        y = n - 1 - row
        for phase, a, b in _phases(brick):
            fill = color if phase == "run" else _PHASE_COLORS[phase]
            if b - a < least and phase != "waiting":
                short[phase] = max(short.get(phase, 0.0), b - a)
            hatch = {"hatch": "////", "edgecolors": "0.55", "linewidth": 0.0} if phase == "waiting" else \
                {"edgecolors": "none"}
            ax.broken_barh([(a, max(b - a, least if phase != "waiting" else 1e-3))], (y - 0.3, 0.6),
                           facecolors=fill, alpha=0.85 if phase == "run" else 1.0, zorder=2, **hatch)
            used.add(phase)
        if brick.start_s is not None:
            lo, hi = brick.start_s
            ax.plot([lo, lo, hi, hi], [y + 0.42, y + 0.36, y + 0.36, y + 0.42], color="black", linewidth=1.0,
                    zorder=4)
            ax.annotate(f"start {lo:.3f}-{hi:.3f} s", (hi, y + 0.36), xytext=(3, 2), textcoords="offset points",
                        fontsize=7, va="bottom", zorder=5)
        others = [(t, e) for t, e, _ in brick.events if e not in MILESTONES]
        if others:
            ts = [t for t, _ in others]
            ax.plot(ts, [y - 0.36] * len(ts), linestyle="none", marker="v", markersize=5, color="crimson", zorder=5)
            shown = others[:_MAX_EVENT_LABELS]
            for k, (t, e) in enumerate(shown):
                ax.annotate(e, (t, y - 0.36), xytext=(2, -9 - 7 * (k % 2)), textcoords="offset points",
                            fontsize=6.5, color="crimson", zorder=5)
            if len(others) > len(shown):
                ax.annotate(f"+{len(others) - len(shown)} more events", (shown[-1][0], y - 0.36), xytext=(40, -9),
                            textcoords="offset points", fontsize=6.5, color="crimson")
    if timeline.stopped is not None:
        t, reason = timeline.stopped
        ax.annotate(f"stopped: {reason}", (t, n - 0.5), xytext=(-4, 2), textcoords="offset points", ha="right",
                    va="bottom", fontsize=7, color="crimson", annotation_clip=False)
    ax.set_yticks(range(n), [b.name for b in reversed(timeline.bricks)], fontsize=8)
    ax.set_ylim(-0.8, n - 0.2)
    lo, hi = timeline.span_s()
    ax.set_xlim(lo, hi + 0.02 * (hi - lo) + 1e-3)
    ax.set_xlabel(f"time (s, {timeline.clock}, from the start of the execution)", fontsize=8)
    ax.tick_params(axis="x", labelsize=7)
    ax.set_title("bricks over time: phases, start intervals, events" + _skew_text(timeline), fontsize=9)
    names = {"run": "run (the robot's colour)",
             "waiting": "waiting for the other bricks (prepared one at a time)" if n > 1 else "waiting"}
    handles = [Patch(facecolor=_PHASE_COLORS[p] or "0.3", hatch="////" if p == "waiting" else None,
                     edgecolor="0.55" if p == "waiting" else None,
                     label=names.get(p, p) + (f" ({short[p] * 1000:.0f} ms: drawn wider)" if p in short else ""))
               for p in _PHASE_COLORS if p in used]
    if handles:
        ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.005, 1.0), frameon=False)
    ax.grid(True, axis="x", linewidth=0.4, alpha=0.5)


def add_time_panels(fig: Figure, specs: Sequence[SubplotSpec], bricks_spec: SubplotSpec, timeline: RunTimeline,
                    colors: Sequence[str], roles: Mapping[str, Mapping[str, str]] | None = None) -> list[Axes]:
    """Draw the panels: ``specs`` holds two cells (angles, error) per brick, in order; ``roles``
    says per brick what each motor port drives (``{"r1": {"A": "carriage wheel"}}``); returns
    every axes made (the time panels share their time axis)."""
    axes: list[Axes] = []
    first: Axes | None = None
    for k, brick in enumerate(timeline.bricks):
        ax_deg = fig.add_subplot(specs[2 * k], sharex=first)
        first = first or ax_deg
        ax_err = fig.add_subplot(specs[2 * k + 1], sharex=first)
        _motor_panels(ax_deg, ax_err, brick, colors[k], (roles or {}).get(brick.name), timeline.clock)
        axes += [ax_deg, ax_err]
    span = timeline.run_span_s()
    if first is not None and span is not None:
        a, b = span
        first.set_xlim(a - 0.02 * (b - a), b + 0.02 * (b - a))
    ax = fig.add_subplot(bricks_spec)
    _bricks_panel(ax, timeline, colors)
    axes.append(ax)
    _mark_stop(axes, timeline)
    return axes
