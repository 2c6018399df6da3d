"""Animations of a run: a two-arm plan is far easier to judge moving than as a still.

`animate_run` draws the arms (rail, carriage, link, hand), the payload and the obstacles tick
by tick: the plan alone (``timeline=None``), or planned (thin, dashed, dark grey) against executed
(solid, from the encoder readings on the PC's clock, so a late brick lags), with the step and
the time shown. `animate_cycles` replays an online run cycle by cycle: the arms and the payload
where the log puts them when the run has a scene, otherwise the state's fluents over the
cycles; with each cycle's actions, events, re-plans and failures.

The files are GIF (Pillow, which matplotlib depends on) or MP4 (ffmpeg, where matplotlib's
animation writers find it, when it is installed), chosen by the file name; `animation_problem` says what is wrong
with a file name before any work is done. Frames are rendered on a bare `Figure` (no pyplot,
no display); ``on_progress(done, total)`` is called after every frame.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import textwrap
from collections.abc import Callable, Sequence
from pathlib import Path

import matplotlib
import numpy as np
import numpy.typing as npt
from matplotlib import animation
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.transforms import Bbox
from PIL import Image

from .errors import TrajectoryError
from .kinematics import choices_at, forward, inverse
from .model import RobotTrajectory, Trajectory
from .plots import PAYLOAD_COLOR, _color, _draw_scene
from .scene import Robot, Scene
from .timeline import CycleFrame, RunTimeline

__all__ = ["animate_run", "animate_cycles", "cycles_figure", "table_rows", "animation_problem", "DEFAULT_MAX_FRAMES",
           "DEFAULT_DPI", "ACTIONS_ROW"]

#: Enough frames for a smooth 10-step plan (a longer run is sampled evenly down to this many).
DEFAULT_MAX_FRAMES = 150
#: Frames 8 inches wide at 100 dpi: 800 pixels.
DEFAULT_DPI = 100
_WRITERS = {".gif": "pillow", ".mp4": "ffmpeg"}

Progress = Callable[[int, int], None]


def animation_problem(path: str | Path) -> str | None:
    """Why an animation cannot be written to ``path`` (its name, or a missing ffmpeg), or None.

    >>> animation_problem("run.gif") is None, animation_problem("run.avi")
    (True, 'use a .gif or .mp4 file name')
    """
    suffix = Path(path).suffix.lower()
    if suffix not in _WRITERS:
        return "use a .gif or .mp4 file name"
    if suffix == ".mp4" and not animation.writers.is_available("ffmpeg"):
        return "an .mp4 needs ffmpeg, which is not installed (install it, or use a .gif file name)"
    return None


def _refuse(path: Path) -> None:
    problem = animation_problem(path)
    if problem is not None:
        raise TrajectoryError(f"cannot animate to {path}: {problem}")


def _write(fig: Figure, draw: Callable[[int], None], frames: int, path: Path, fps: float, dpi: int,
           on_progress: Progress | None, moving: Sequence[Artist] | None = None) -> Path:
    """Render ``frames`` frames (``draw(i)`` updates the figure for frame ``i``) into ``path``.

    Frames are rendered on an Agg canvas; with ``moving`` (the only artists ``draw`` changes)
    the rest is rendered once and every frame only redraws those, ten times faster than a
    whole figure per frame. A GIF is assembled by Pillow; an MP4 is encoded by ffmpeg (the one
    matplotlib's animation writers use), fed the raw frames. The file appears whole or not at
    all (written beside it, then renamed)."""
    _refuse(path)
    if frames < 1:
        raise TrajectoryError("an animation needs at least one frame")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.set_dpi(dpi)
    canvas = FigureCanvasAgg(fig)
    moving = sorted(moving or (), key=lambda a: a.get_zorder())   # blitting draws in this order
    for artist in moving:
        artist.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox) if moving else None
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp{path.suffix}")
    sink = _Mp4(tmp, canvas.get_width_height(), fps) if _WRITERS[path.suffix.lower()] == "ffmpeg" else _Gif(tmp, fps)
    try:
        for i in range(frames):
            draw(i)
            if background is not None:
                canvas.restore_region(background)
                for artist in moving:
                    fig.draw_artist(artist)
            else:
                canvas.draw()
            sink.add(canvas)
            if on_progress is not None:
                on_progress(i + 1, frames)
        sink.close()
        tmp.replace(path)
    finally:
        sink.abort()
        if tmp.exists():
            tmp.unlink()
    return path


class _Gif:
    """Frames kept as palette images, written by Pillow at the end."""

    def __init__(self, path: Path, fps: float) -> None:
        self.path, self.fps = path, fps
        self.images: list[Image.Image] = []

    def add(self, canvas: FigureCanvasAgg) -> None:
        image = Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
        self.images.append(image.convert("RGB").quantize(colors=128, method=Image.Quantize.FASTOCTREE))

    def close(self) -> None:
        self.images[0].save(self.path, format="GIF", save_all=True, append_images=self.images[1:],
                            duration=round(1000 / self.fps), loop=0)

    def abort(self) -> None:
        self.images.clear()


class _Mp4:
    """Frames piped to ffmpeg as raw RGBA, encoded H.264 (even dimensions, yuv420p: what players take)."""

    def __init__(self, path: Path, size: tuple[int, int], fps: float) -> None:
        width, height = size
        command = [str(matplotlib.rcParams["animation.ffmpeg_path"]), "-y", "-loglevel", "error",
                   "-f", "rawvideo", "-pix_fmt", "rgba", "-s", f"{width}x{height}", "-r", f"{fps:g}", "-i", "-",
                   "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2:color=white", "-c:v", "libx264", "-pix_fmt", "yuv420p",
                   "-f", "mp4", str(path)]
        self.proc: subprocess.Popen[bytes] | None = subprocess.Popen(
            command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)

    def add(self, canvas: FigureCanvasAgg) -> None:
        assert self.proc is not None and self.proc.stdin is not None
        try:
            self.proc.stdin.write(bytes(canvas.buffer_rgba()))
        except BrokenPipeError:
            self.close()

    def close(self) -> None:
        proc, self.proc = self.proc, None
        if proc is None:
            return
        _, err = proc.communicate()
        if proc.returncode != 0:
            detail = err.decode("utf-8", "replace").strip().splitlines()
            raise TrajectoryError(f"ffmpeg failed (exit {proc.returncode})" + (f": {detail[-1]}" if detail else ""))

    def abort(self) -> None:
        proc, self.proc = self.proc, None
        if proc is not None:
            proc.kill()
            proc.wait()


def _check(max_frames: int, dpi: int, fps: float | None) -> None:
    if max_frames < 1:
        raise TrajectoryError(f"max_frames must be at least 1, not {max_frames}")
    if not 10 <= dpi <= 600:
        raise TrajectoryError(f"dpi must be from 10 to 600, not {dpi}")
    if fps is not None and not (math.isfinite(fps) and 0 < fps <= 60):
        raise TrajectoryError(f"fps must be in (0, 60], not {fps}")


def _sample(n: int, max_frames: int) -> npt.NDArray[np.int64]:
    """``min(n, max_frames)`` indices from 0 to n - 1, evenly spread, first and last included."""
    return np.unique(np.linspace(0, n - 1, min(n, max_frames)).round().astype(np.int64))


def _view(ax: Axes, scene: Scene, carriages: Sequence[tuple[float, float]] = ()) -> None:
    """The grid's view widened to show the carriages where they go and the rails under them."""
    g = scene.grid
    known = [(x, y) for x, y in carriages if math.isfinite(x) and math.isfinite(y)]
    xs = [min([g.x_min - 1.5] + [x - 0.8 for x, _ in known]), max([g.x_max + 1.5] + [x + 0.8 for x, _ in known])]
    ys = [g.y_min - 1.5, g.y_max + 1.5] + [y for _, y in known]
    for robot in scene.robots:
        ys += [y for _, y in _rail(robot, xs)]
    ax.set_ylim(min(ys) - 0.6, max(ys) + 0.6)
    ax.set_xlim(*xs)


def _fit(fig: Figure, ax: Axes, side: float = 1.9) -> None:
    """Size the figure to the view (equal aspect), with ``side`` inches on the right for the legend."""
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    width = 8.0 - side
    height = min(7.0, max(3.0, width * (y1 - y0) / (x1 - x0)))
    fig.set_size_inches(8.0, height + 1.2)
    fig.subplots_adjust(left=0.6 / 8.0, right=(8.0 - side + 0.6) / 8.0 - 0.02, bottom=0.55 / (height + 1.2),
                        top=1 - 0.65 / (height + 1.2))


def _carriage(robot: Robot, s: npt.ArrayLike) -> list[tuple[float, float]]:
    (ox, oy), (dx, dy) = robot.arm.rail_origin, robot.arm.rail_dir
    return [(ox + v * dx, oy + v * dy) for v in np.ravel(np.asarray(s, dtype=float))]


def _rail(robot: Robot, xs: Sequence[float]) -> list[tuple[float, float]]:
    """The rail's ends, clipped to its limits (and, along x, to the view when the rail runs along x)."""
    arm = robot.arm
    lo, hi = arm.s_limits
    (ox, oy), (dx, dy) = arm.rail_origin, arm.rail_dir
    if abs(dx) > 1e-9:
        a, b = sorted(((xs[0] - ox) / dx, (xs[1] - ox) / dx))
        lo, hi = max(lo, a), min(hi, b)
    return [(ox + lo * dx, oy + lo * dy), (ox + hi * dx, oy + hi * dy)]


class _ArmArtist:
    """One arm drawn as a carriage, a link and a hand (its rail is drawn once); ``ghost`` is the
    planned arm under an executed one: thin, dashed, dark grey and on top, so that it shows
    wherever the two part."""

    def __init__(self, ax: Axes, robot: Robot, color: str, ghost: bool) -> None:
        self.arm = robot.arm
        if ghost:
            color, z, link = "0.2", 7.5, {"linestyle": (0, (3, 2)), "linewidth": 1.3, "alpha": 0.8}
        else:
            z, link = 6.0, {"linewidth": 3.0}
        (self.link,) = ax.plot([], [], color=color, solid_capstyle="round", zorder=z, **link)  # type: ignore[arg-type]
        (self.carriage,) = ax.plot([], [], marker="s", markersize=5 if ghost else 9, linestyle="none",
                                   markerfacecolor="none" if ghost else color, markeredgecolor=color, zorder=z)
        (self.hand,) = ax.plot([], [], marker="o", markersize=5 if ghost else 7, linestyle="none",
                               markerfacecolor="none" if ghost else "white", markeredgecolor=color,
                               markeredgewidth=1.2 if ghost else 2, zorder=z + 0.5)
        self.artists: list[Artist] = [self.link, self.carriage, self.hand]

    def show(self, s: float, theta_rad: float) -> tuple[float, float]:
        if not (math.isfinite(s) and math.isfinite(theta_rad)):
            for artist in (self.link, self.carriage, self.hand):
                artist.set_data([], [])
            return (math.nan, math.nan)
        (ox, oy), (dx, dy) = self.arm.rail_origin, self.arm.rail_dir
        cx, cy = ox + s * dx, oy + s * dy
        x, y = (float(v) for v in forward(self.arm, s, theta_rad))
        self.link.set_data([cx, x], [cy, y])
        self.carriage.set_data([cx], [cy])
        self.hand.set_data([x], [y])
        return (x, y)


def _executed_joints(robot: RobotTrajectory, timeline: RunTimeline, ticks: npt.NDArray[np.int64]
                     ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The executed ``(s, theta_rad)`` of ``robot`` at the common ``ticks``: its brick's own tick
    is shifted by how much later it started than the first brick, and its encoder rows are
    interpolated; NaN where nothing was measured (before its start: its first reading)."""
    nan = np.full(len(ticks), np.nan)
    try:
        brick = timeline.brick(robot.name)
    except KeyError:
        return nan, nan
    first, start = timeline.first_start_s, brick.start_mid_s
    rows = brick.measured_deg
    known = np.flatnonzero(np.all(np.isfinite(rows), axis=1))
    if first is None or start is None or not len(known):
        return nan, nan
    own = ticks - (start - first) / brick.tick_s
    cols = [np.interp(np.clip(own, known[0], known[-1]), known, rows[known, j]) for j in range(rows.shape[1])]
    s, theta = robot.joints_from_motor_deg(np.column_stack(cols))
    beyond = own > known[-1] + 1e-9
    return np.where(beyond, np.nan, s), np.where(beyond, np.nan, theta)


def _lag_ticks(traj: Trajectory, timeline: RunTimeline) -> int:
    """How many ticks after the first brick the last one started (rounded up)."""
    first = timeline.first_start_s
    lags = [(b.start_mid_s - first) / b.tick_s for b in timeline.bricks
            if first is not None and b.start_mid_s is not None and b.name in {r.name for r in traj.robots}]
    return max(0, math.ceil(max(lags, default=0.0) - 1e-9))


def animate_run(scene: Scene, traj: Trajectory, path: str | Path, *, timeline: RunTimeline | None = None,
                title: str | None = None, max_frames: int = DEFAULT_MAX_FRAMES, dpi: int = DEFAULT_DPI,
                fps: float | None = None, on_progress: Progress | None = None) -> Path:
    """Animate a trajectory over its scene and save it (GIF, or MP4 with ffmpeg).

    Without ``timeline`` the plan moves alone; with one (an execution's `RunTimeline`) the
    executed arms move over the planned ones, on the first brick's clock: a brick that started
    late lags, and the animation lasts until it ends. One frame per tick, sampled evenly down
    to ``max_frames``; ``fps`` defaults to the pace of the trajectory's own clock (between 2 and 25
    frames a second). Returns the path written.

    Raises:
        TrajectoryError: a bad file name, no ffmpeg for an .mp4, a robot not in the scene, or
            bad ``max_frames``/``dpi``/``fps``.
    """
    out = Path(path)
    _refuse(out)
    _check(max_frames, dpi, fps)
    names = list(scene.robot_names)
    for r in traj.robots:
        if r.name not in names:
            raise TrajectoryError(f"cannot animate robot {r.name}: it is not in the scene")
    n = traj.ticks
    tick_s = traj.tick_ms / 1000.0
    span = n + (_lag_ticks(traj, timeline) if timeline is not None else 0)   # a late brick ends later
    ticks = _sample(span, max_frames)
    rate = fps if fps is not None else min(25.0, max(2.0, len(ticks) / max(span * tick_s, 1e-9)))
    fig = Figure(figsize=(8, 6))
    ax = fig.add_subplot()
    _draw_scene(ax, scene)
    joints: dict[str, tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]] = {}
    carriages: list[tuple[float, float]] = []
    for r in traj.robots:
        carriages += _carriage(scene.robot(r.name), r.s)
        if timeline is not None:
            joints[r.name] = _executed_joints(r, timeline, ticks)
            carriages += _carriage(scene.robot(r.name), joints[r.name][0])
    _view(ax, scene, carriages)
    planned: dict[str, _ArmArtist] = {}
    executed: dict[str, _ArmArtist] = {}
    trails: dict[str, Line2D] = {}
    xs = [ax.get_xlim()[0], ax.get_xlim()[1]]
    for r in traj.robots:
        k = names.index(r.name)
        robot, color = scene.robot(r.name), _color(k)
        (a, b) = _rail(robot, xs)
        ax.plot([a[0], b[0]], [a[1], b[1]], color="0.55", linewidth=5, alpha=0.5, solid_capstyle="butt", zorder=1.5)
        ax.plot(r.x, r.y, color=color, linewidth=0.9, linestyle=":", alpha=0.8, zorder=3)
        planned[r.name] = _ArmArtist(ax, robot, color, ghost=timeline is not None)
        if timeline is not None:
            executed[r.name] = _ArmArtist(ax, robot, color, ghost=False)
            (trails[r.name],) = ax.plot([], [], color=color, linewidth=1.4, zorder=4)
    pair = traj.robots[:2] if len(traj.robots) >= 2 else ()
    (pay_plan,) = ax.plot([], [], color=PAYLOAD_COLOR, linewidth=4, zorder=5,
                          alpha=0.45 if timeline is not None else 0.9, solid_capstyle="round",
                          linestyle="--" if timeline is not None else "-")
    (pay_exec,) = ax.plot([], [], color=PAYLOAD_COLOR, linewidth=4, zorder=5.5, solid_capstyle="round")
    stamp = ax.text(0.0, 1.01, "", transform=ax.transAxes, ha="left", va="bottom", fontsize=9, zorder=9,
                    family="monospace")
    handles = [Line2D([], [], color=_color(names.index(r.name)), linewidth=3, label=f"robot {r.name}")
               for r in traj.robots]
    handles.append(Line2D([], [], color=PAYLOAD_COLOR, linewidth=4, label="payload"))
    if timeline is not None:
        handles += [Line2D([], [], color="0.3", linewidth=3, label="executed"),
                    Line2D([], [], color="0.2", linewidth=1.3, linestyle=(0, (3, 2)), alpha=0.8, label="planned")]
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    kind = "planned" if timeline is None else "executed (solid) vs planned (dashed)"
    fig.suptitle(title or f"{scene.name}: {kind}", fontsize=11)
    m = traj.plan_length
    _fit(fig, ax)
    moving: list[Artist] = [pay_plan, pay_exec, stamp, *trails.values()]
    for arm in [*planned.values(), *executed.values()]:
        moving += arm.artists

    def draw(i: int) -> None:
        j = min(int(ticks[i]), n - 1)
        hands_plan: dict[str, tuple[float, float]] = {}
        hands_exec: dict[str, tuple[float, float]] = {}
        missing = []
        for r in traj.robots:
            hands_plan[r.name] = planned[r.name].show(float(r.s[j]), math.radians(float(r.theta_deg[j])))
            if timeline is not None:
                s, th = joints[r.name]
                hands_exec[r.name] = executed[r.name].show(float(s[i]), float(th[i]))
                if not math.isfinite(hands_exec[r.name][0]):
                    missing.append(r.name)
                keep = np.isfinite(s[: i + 1])
                if keep.any():
                    tx, ty = forward(r.arm, s[: i + 1][keep], th[: i + 1][keep])
                    trails[r.name].set_data(tx, ty)
        if pair:
            p, q = hands_plan[pair[0].name], hands_plan[pair[1].name]
            pay_plan.set_data([p[0], q[0]], [p[1], q[1]])
            if timeline is not None:
                p, q = hands_exec[pair[0].name], hands_exec[pair[1].name]
                pay_exec.set_data([p[0], q[0]], [p[1], q[1]])
        step = int(traj.robots[0].step[j])
        frac = j / traj.points_per_step - step
        where = f"step {step}" if frac < 1e-9 or step >= m else f"step {step} -> {step + 1}"
        text = f"{where} of {m}   t = {int(ticks[i]) * tick_s:.2f} s   tick {j}/{n - 1}"
        if missing:
            text += "\nno measurement: " + ", ".join(missing)
        stamp.set_text(text)

    return _write(fig, draw, len(ticks), out, rate, dpi, on_progress, moving)


def _ik(robot: Robot, x: float, y: float) -> tuple[float, float]:
    """Joint values holding ``robot``'s hand at (x, y), on its preferred branch when it can
    (NaN: nowhere within its limits)."""
    choices = choices_at(robot.arm, x, y)
    if not choices:
        return (math.nan, math.nan)
    preferred = [c for c in choices if robot.branch is not None and c.branch == robot.branch]
    s, th = inverse(robot.arm, x, y, (preferred or list(choices))[0])
    return float(s), float(th)


def _trail_segments(points: Sequence[tuple[int, tuple[float, float]]], jumps: bool) -> tuple[list, list]:
    """The hand's trail as line data: between consecutive cycles (``jumps`` False) or between
    cycles that several steps apart (the arms ran several steps in one cycle; the log has the
    ends only), NaN-separated."""
    xs: list[float] = []
    ys: list[float] = []
    for (c0, p), (c1, q) in zip(points, points[1:]):
        if (c1 - c0 > 1) == jumps:
            xs += [p[0], q[0], math.nan]
            ys += [p[1], q[1], math.nan]
    return xs, ys


def _cycle_scene(ax: Axes, scene: Scene, frames: Sequence[CycleFrame]) -> Callable[[int], None]:
    """The arms and the payload where each cycle's state puts them, with the hands' trails: solid
    between consecutive cycles, dotted across cycles that ran several steps (where the arms went
    in between is not in the log). A re-plan is starred where it was made, a failure crossed
    where the failing cycle left the arms (the next cycle's place)."""
    _draw_scene(ax, scene)
    carriages = []
    for f in frames:
        for robot in scene.robots:
            if robot.name in f.positions:
                carriages += _carriage(robot, _ik(robot, *f.positions[robot.name])[0])
    _view(ax, scene, carriages)
    names = list(scene.robot_names)
    xs = [ax.get_xlim()[0], ax.get_xlim()[1]]
    arms, trails, leaps = {}, {}, {}
    for k, robot in enumerate(scene.robots):
        (a, b) = _rail(robot, xs)
        ax.plot([a[0], b[0]], [a[1], b[1]], color="0.55", linewidth=5, alpha=0.5, solid_capstyle="butt", zorder=1.5)
        arms[robot.name] = _ArmArtist(ax, robot, _color(k), ghost=False)
        (trails[robot.name],) = ax.plot([], [], color=_color(k), linewidth=1.2, zorder=4)
        (leaps[robot.name],) = ax.plot([], [], color=_color(k), linewidth=1.0, linestyle=(0, (1, 2.5)), zorder=4)
    e1, e2 = scene.end_names
    (pay,) = ax.plot([], [], color=PAYLOAD_COLOR, linewidth=4, solid_capstyle="round", zorder=5)
    (dots,) = ax.plot([], [], color="0.2", marker=".", markersize=5, linestyle="none", zorder=4.2)
    # a failure is often where the run re-planned: the star is drawn large and the cross small
    # on top of it, so that both show at one place
    (replans,) = ax.plot([], [], linestyle="none", marker="*", markersize=22, color="darkorange",
                         markeredgecolor="white", markeredgewidth=0.8, zorder=8, label="re-planned here")
    (failures,) = ax.plot([], [], linestyle="none", marker="X", markersize=8, color="crimson",
                          markeredgecolor="white", markeredgewidth=0.8, zorder=8.5, label="failure here")
    handles = [Line2D([], [], color=_color(k), linewidth=3, label=f"robot {n}") for k, n in enumerate(names)]
    handles.append(Line2D([], [], color="0.3", linewidth=1.0, linestyle=(0, (1, 2.5)),
                          label="several steps in one cycle"))
    ax.legend(handles=[*handles, replans, failures], loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=3, fontsize=8,
              frameon=False)
    anchor = names[0]

    def failed_at(j: int) -> tuple[float, float] | None:
        """Where cycle ``j``'s failure left the arms: the next frame's place, else its own."""
        later = frames[j + 1].positions.get(anchor) if j + 1 < len(frames) else None
        return later if later is not None else frames[j].positions.get(anchor)

    def draw(i: int) -> None:
        marks: dict[str, list[tuple[float, float]]] = {"replan": [], "fail": []}
        hands: list[tuple[float, float]] = []
        for robot in scene.robots:
            past = [(f.cycle, f.positions[robot.name]) for f in frames[: i + 1]
                    if robot.name in f.positions and not f.ended]
            trails[robot.name].set_data(*_trail_segments(past, jumps=False))
            leaps[robot.name].set_data(*_trail_segments(past, jumps=True))
            hands += [p for _, p in past]
            here = frames[i].positions.get(robot.name)
            arms[robot.name].show(*(_ik(robot, *here) if here else (math.nan, math.nan)))
        dots.set_data([p[0] for p in hands], [p[1] for p in hands])
        for j, f in enumerate(frames[: i + 1]):          # marked at the first robot's hand
            at = f.positions.get(anchor)
            if at is not None and f.replanned:
                marks["replan"].append(at)
            where = (at if f.ended else failed_at(j)) if f.failed else None
            if where is not None:
                marks["fail"].append(where)
        replans.set_data([p[0] for p in marks["replan"]], [p[1] for p in marks["replan"]])
        failures.set_data([p[0] for p in marks["fail"]], [p[1] for p in marks["fail"]])
        ends = frames[i].positions
        if e1 in ends and e2 in ends:
            pay.set_data([ends[e1][0], ends[e2][0]], [ends[e1][1], ends[e2][1]])
        else:
            pay.set_data([], [])
    return draw


_TABLE_COLUMNS = 10
_TABLE_ROWS = 24
ACTIONS_ROW = "actions executed"
"""The table's first row: what each cycle executed (the rows below are the state's fluents)."""


def _natural(name: str) -> tuple:
    """Sort key of a fluent's name: ``letter(2)`` before ``letter(10)``, by constant, then arguments."""
    return tuple((0, int(part), "") if part.isdigit() else (1, 0, part) for part in re.split(r"(\d+)", name))


def table_rows(frames: Sequence[CycleFrame]) -> tuple[list[str], int]:
    """The fluents the table shows, in their names' order (``letter(1)``, ``letter(2)``, ...):
    those whose value changes over the run first chosen, then the others, up to the table's
    size; and how many were left out."""
    fluents: list[str] = []
    for f in frames:
        fluents += [k for k in f.state if k not in fluents]
    changing = [k for k in fluents if len({f.state.get(k) for f in frames}) > 1]
    chosen = (changing + [k for k in fluents if k not in changing])[:_TABLE_ROWS]
    return sorted(chosen, key=_natural), len(fluents) - len(chosen)


def _actions_text(actions: Sequence[str]) -> str:
    if not actions:
        return "-"
    text = "\n".join(actions[:2])
    return text + (f"\n+{len(actions) - 2} more" if len(actions) > 2 else "")


def _cycle_table(ax: Axes, frames: Sequence[CycleFrame]) -> Callable[[int], None]:
    """The actions and the state's fluents over the last cycles, a changed value shaded, the
    current cycle framed; the table fills the axes whatever the number of rows."""
    rows, hidden = table_rows(frames)

    def draw(i: int) -> None:
        ax.clear()
        ax.set_axis_off()
        lo = max(0, i - _TABLE_COLUMNS + 1)
        cols = list(range(lo, i + 1))
        header = [("end" if frames[c].ended else f"{frames[c].cycle}") + ("\nre-plan" if frames[c].replanned else "")
                  + ("\nfailure" if frames[c].failed else "") for c in cols]
        if not rows:
            ax.text(0.5, 0.5, "no state in the log", ha="center", va="center", transform=ax.transAxes)
            return
        cells = [[_actions_text(frames[c].actions) if not frames[c].ended else "" for c in cols]]
        colours = [["#eef3fb"] * len(cols)]
        for name in rows:
            line, shade = [], []
            for c in cols:
                value = frames[c].state.get(name, "")
                before = frames[c - 1].state.get(name, "") if c > 0 else value
                line.append(value)
                shade.append("#fff3b0" if value != before else "white")
            cells.append(line)
            colours.append(shade)
        # the table fills the axes: the header takes the room of two rows, the actions row of two
        table = ax.table(cellText=cells, cellColours=colours, rowLabels=[ACTIONS_ROW, *rows], colLabels=header,
                         cellLoc="center", bbox=Bbox.from_bounds(0.0, 0.0, 1.0, 1.0))
        table.auto_set_font_size(False)
        size = 8 if len(rows) <= 16 else 7
        table.set_fontsize(size)
        n = len(rows) + 4
        for (r, c), cell in table.get_celld().items():
            cell.set_height((2 if r in (0, 1) else 1) / n)
            if c == len(cols) - 1 and r >= 0:
                cell.set_edgecolor("black")
                cell.set_linewidth(1.6)
            if r == 1:
                cell.get_text().set_fontsize(size - 1)
                if c < 0:
                    cell.get_text().set_fontweight("bold")
            if r == 0 and c >= 0:
                if frames[cols[c]].failed:
                    cell.set_facecolor("#f4b6b6")
                elif frames[cols[c]].replanned:
                    cell.set_facecolor("#ffd8a8")
        note = "cycles (columns): the actions each executed, then the state's fluents; a shaded value changed then"
        if hidden:
            note += f"; {hidden} more fluents not shown"
        ax.set_title(note, fontsize=8, loc="left")
    return draw


def _literal():
    """Text drawn as written: a log's text may hold ``$...$`` (a request a socket client sent),
    which matplotlib would read as mathematics and may fail to parse."""
    return matplotlib.rc_context({"text.parse_math": False, "text.usetex": False})


def _cycles_figure(chosen: Sequence[CycleFrame], scene: Scene | None, title: str | None,
                   last: int) -> tuple[Figure, Callable[[int], None]]:
    fig = Figure(figsize=(12, 6))
    grid = fig.add_gridspec(1, 2, width_ratios=(2.5, 1.5))
    ax = fig.add_subplot(grid[0, 0])
    side = fig.add_subplot(grid[0, 1])
    side.set_axis_off()
    with_scene = scene is not None and any(f.positions for f in chosen)
    draw_main = _cycle_scene(ax, scene, chosen) if with_scene and scene is not None else _cycle_table(ax, chosen)
    fig.suptitle(title or "online run", fontsize=11)
    trace = side.text(0.0, 1.0, "", ha="left", va="top", fontsize=7.5, family="monospace", transform=side.transAxes)
    fig.subplots_adjust(left=0.16 if not with_scene else 0.06, right=0.98, top=0.9 if with_scene else 0.88,
                        bottom=0.06 if with_scene else 0.03, wspace=0.12)

    def draw(i: int) -> None:
        draw_main(i)
        f = chosen[i]
        lines = ["the end of the run" if f.ended else f"cycle {f.cycle} of {last}", f"t = {f.time_s:.2f} s", ""]
        for line in f.lines:
            lines += textwrap.wrap(line, 62, subsequent_indent="  ") or [""]
        trace.set_text("\n".join(lines[:40]))
        trace.set_color("crimson" if f.failed else "black")
    return fig, draw


def cycles_figure(frames: Sequence[CycleFrame], frame: int = -1, *, scene: Scene | None = None,
                  title: str | None = None) -> Figure:
    """The figure `animate_cycles` draws for one of ``frames`` (default: the last), unsaved:
    its table, marks, legend and texts can be inspected."""
    if not frames:
        raise TrajectoryError("the run has no cycle to replay")
    with _literal():
        fig, draw = _cycles_figure(frames, scene, title, frames[-1].cycle)
        draw(range(len(frames))[frame])
    return fig


def animate_cycles(frames: Sequence[CycleFrame], path: str | Path, *, scene: Scene | None = None,
                   title: str | None = None, max_frames: int = DEFAULT_MAX_FRAMES, dpi: int = DEFAULT_DPI,
                   fps: float | None = None, on_progress: Progress | None = None) -> Path:
    """Replay an online run, one frame per cycle (sampled evenly down to ``max_frames``; ``fps``
    defaults to 1 frame a second for a few cycles, up to 4 for many), and save it.

    With ``scene`` and positions in the frames, the arms and the payload move over the scene;
    otherwise the actions and the state's fluents are shown as a table over the last cycles.
    Beside it, the cycle's trace: the time, the actions, the events, the re-plan, the failure.
    Every text is drawn as written (no mathematics between ``$`` signs).

    Raises:
        TrajectoryError: no frames, a bad file name, no ffmpeg for an .mp4, or bad options.
    """
    out = Path(path)
    _refuse(out)
    _check(max_frames, dpi, fps)
    if not frames:
        raise TrajectoryError("the run has no cycle to replay")
    chosen = [frames[int(k)] for k in _sample(len(frames), max_frames)]
    rate = fps if fps is not None else min(4.0, max(1.0, len(chosen) / 15.0))
    with _literal():
        fig, draw = _cycles_figure(chosen, scene, title, frames[-1].cycle)
        return _write(fig, draw, len(chosen), out, rate, dpi, on_progress)
