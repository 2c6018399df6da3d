"""Pictures in the style of the paper's Figs 2 and 5 (PNG or SVG, no screen needed).

Colours follow the paper: obstacles black, robot 1 blue, robot 2 red, the payload green.
Circles with step labels mark the end-effector positions of the plan (a boxed label beside a
circle names every step drawn there, and a step at which nothing moves is explained under the
plot); a green line joins the payload's ends at every step. `plot_plan` also highlights a violation: the region the payload
sweeps during the failing motion is shaded, the point of first contact is crossed, and the
message is printed under the plot. `plot_execution` draws planned against executed
end-effector paths, with thin green payload segments along the executed motion (Fig. 5), and
with a `RunTimeline` the run over time below (`trajectory.time_panels`).

Figures are built with `matplotlib.figure.Figure` directly (Agg and SVG canvases), so plotting
never touches pyplot's global state or a display.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib
import matplotlib.colors
import numpy as np
import numpy.typing as npt
import shapely
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PolygonPatch
from matplotlib.text import Annotation, Text

from .checker import Violation
from .errors import TrajectoryError
from .geometry import lerp
from .scene import Scene
from .states import StepState
from .time_panels import add_time_panels
from .timeline import RunTimeline

__all__ = ["plot_plan", "plot_execution", "plan_figure", "execution_figure", "plan_title", "motor_roles",
           "still_steps", "swept_region_for_display", "ROBOT_COLORS"]

ROBOT_COLORS = ("tab:blue", "tab:red", "tab:purple", "tab:orange", "tab:brown", "tab:cyan")
PAYLOAD_COLOR = "tab:green"
_FORMATS = {".png": "png", ".svg": "svg"}


def _format_of(path: Path) -> str:
    fmt = _FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise TrajectoryError(f"cannot plot to {path}: use a .png or .svg file name")
    return fmt


def _color(k: int) -> str:
    return ROBOT_COLORS[k % len(ROBOT_COLORS)]


def _darker(color: str) -> tuple[float, float, float]:
    """The colour at half its brightness: a robot's planned path over its executed one."""
    r, g, b = matplotlib.colors.to_rgb(color)
    return (r * 0.45, g * 0.45, b * 0.45)


_JOINT_ROLES = {"s": "carriage wheel", "theta": "arm"}


def motor_roles(scene: Scene) -> dict[str, dict[str, str]]:
    """What each motor of each robot drives, as the execution picture's legends say it:
    ``{"r1": {"A": "carriage wheel", "B": "carriage wheel", "C": "arm"}}`` (the scene's
    ``joint``: ``s`` moves the carriage along its rail, ``theta`` turns the arm)."""
    return {r.name: {m.port: _JOINT_ROLES.get(m.joint, m.joint) for m in r.motors} for r in scene.robots}


def swept_region_for_display(a1: Sequence[float], a2: Sequence[float], b1: Sequence[float],
                             b2: Sequence[float], samples: int = 64) -> shapely.Geometry:
    """An outline of the region the payload sweeps, for drawing only.

    Made of the quadrilaterals between ``samples`` intermediate positions of the segment;
    the checker never uses it (its test is exact, see `geometry`).

    >>> region = swept_region_for_display((0, 0), (0, 5), (4, 0), (4, 5))   # slid 4 to the right
    >>> [round(v, 2) for v in region.bounds], round(region.area, 1)
    ([-0.0, -0.0, 4.0, 5.0], 20.0)
    """
    pieces = []
    us = np.linspace(0.0, 1.0, samples + 1)
    segs = [(lerp(tuple(a1), tuple(b1), u), lerp(tuple(a2), tuple(b2), u)) for u in us]  # type: ignore[arg-type]
    for (p, q), (r, s) in zip(segs, segs[1:]):
        quad = shapely.Polygon([p, q, s, r])
        pieces.append(quad if quad.is_valid else shapely.make_valid(quad))
        pieces.append(shapely.LineString([p, q]).buffer(1e-3))
    return shapely.union_all(pieces)


def _draw_scene(ax: Axes, scene: Scene) -> None:
    g = scene.grid
    xs, ys = np.meshgrid(np.arange(g.x_min, g.x_max + 1), np.arange(g.y_min, g.y_max + 1))
    ax.plot(xs.ravel(), ys.ravel(), linestyle="none", marker=".", markersize=2, color="0.75", zorder=1,
            label="grid points (the plan's positions)")
    ax.plot([g.x_min, g.x_max, g.x_max, g.x_min, g.x_min], [g.y_min, g.y_min, g.y_max, g.y_max, g.y_min],
            color="0.6", linewidth=0.8, linestyle=":", zorder=1, label="grid bounds")
    for k, obstacle in enumerate(scene.obstacles):
        coords = shapely.get_coordinates(obstacle.polygon.exterior)
        ax.add_patch(PolygonPatch(coords, closed=True, facecolor="0.15", edgecolor="black",
                                  linewidth=1.2, zorder=2, label="obstacles" if k == 0 else None))
    ax.set_aspect("equal")
    unit = f" (1 unit = {g.unit_mm:g} mm)" if g.unit_mm else " (grid units)"
    ax.set_xlabel("x" + unit)
    ax.set_ylabel("y")
    ax.set_xlim(g.x_min - 1.5, g.x_max + 1.5)
    ax.set_ylim(g.y_min - 1.5, g.y_max + 1.5)


def _draw_states(ax: Axes, scene: Scene, states: Sequence[StepState], *, paths: bool) -> list[Annotation]:
    """Payload lines and labelled end-effector circles at every state (and the plan's paths);
    returns the boxed labels of steps drawn at one place."""
    boxed: list[Annotation] = []
    e1, e2 = scene.end_names
    for i, st in enumerate(states):
        a, b = st.payload[e1], st.payload[e2]
        ax.plot([a[0], b[0]], [a[1], b[1]], color=PAYLOAD_COLOR, linewidth=2.5, alpha=0.9, zorder=3,
                solid_capstyle="round", label="payload (plan)" if i == 0 else None)
    for k, robot in enumerate(scene.robots):
        pts = np.array([st.robots[robot.name] for st in states])
        color = _color(k)
        if paths:
            ax.plot(pts[:, 0], pts[:, 1], color=color, linewidth=1.5, zorder=4, label=f"robot {robot.name}")
        ax.plot(pts[:, 0], pts[:, 1], linestyle="none", marker="o", markersize=11,
                markerfacecolor="white", markeredgecolor=color, markeredgewidth=1.5, zorder=5)
        steps_at: dict[tuple[float, float], list[int]] = {}
        for i, (x, y) in enumerate(pts):
            steps_at.setdefault((float(x), float(y)), []).append(i)
        for (x, y), steps in steps_at.items():
            ax.annotate(str(steps[0]), (x, y), ha="center", va="center", fontsize=7.5, color=color, zorder=6)
            if len(steps) == 1:
                continue
            # several steps at one place: the circle keeps the first, a boxed label beside it names them all
            # (placed where it covers no obstacle, circle or other label: `_place_labels`)
            boxed.append(ax.annotate(_steps_text(steps), (x, y), xytext=(9, 7), textcoords="offset points",
                                     ha="left", va="bottom", fontsize=8, color=color, zorder=6,
                                     bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": color,
                                           "linewidth": 0.6, "alpha": 0.9}))
    return boxed


_STEP_SPOTS = ((9, 7, "left", "bottom"), (9, -7, "left", "top"), (-9, 7, "right", "bottom"),
               (-9, -7, "right", "top"), (0, 11, "center", "bottom"), (0, -11, "center", "top"),
               (13, 0, "left", "center"), (-13, 0, "right", "center"), (16, 16, "left", "bottom"),
               (-16, -16, "right", "top"))
"""Where a boxed step label may go, in points from its circle, in order of preference."""

_CIRCLE_PT = 11.0
"""The diameter of a step's circle (its marker size)."""


def _renderer(fig: Figure):
    """A renderer to measure texts with (an Agg canvas is attached to a bare figure)."""
    canvas = fig.canvas
    if not hasattr(canvas, "get_renderer"):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        canvas = FigureCanvasAgg(fig)
    return canvas.get_renderer()


def _box(artist: Text, renderer, pad: float = 0.0) -> shapely.Polygon:
    bb = artist.get_window_extent(renderer)
    return shapely.box(bb.x0 - pad, bb.y0 - pad, bb.x1 + pad, bb.y1 + pad)


def _settle(ann: Annotation, spots: Sequence[tuple[float, float, str, str]], renderer, free) -> shapely.Polygon:
    """Put ``ann`` at the first of ``spots`` (offset points, alignment) where ``free(box)`` holds,
    else at the first; returns its box (display units)."""
    for dx, dy, ha, va in [*spots, spots[0]]:
        ann.xyann = (dx, dy)
        ann.set(horizontalalignment=ha, verticalalignment=va)
        box = _box(ann, renderer, pad=3.0)
        if free(box):
            break
    return box


def _place_labels(ax: Axes, scene: Scene, states: Sequence[StepState], boxed: Sequence[Annotation]) -> None:
    """Name every obstacle (inside it in white when the name fits, else beside it), and move each
    boxed step label to where it covers no obstacle, no circle and no other label."""
    fig = ax.get_figure()
    assert isinstance(fig, Figure)
    renderer = _renderer(fig)
    ax.apply_aspect()
    to_px = ax.transData.transform
    view_px = _box(ax, renderer)  # type: ignore[arg-type]
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    view = shapely.box(x0, y0, x1, y1)
    shapes = [shapely.Polygon(to_px(shapely.get_coordinates(o.polygon.exterior))) for o in scene.obstacles]
    radius = _CIRCLE_PT / 2 * fig.dpi / 72 + 1.0
    circles = [shapely.Point(to_px(p)).buffer(radius) for st in states for p in st.robots.values()]
    taken: list[shapely.Polygon] = []

    def free(box: shapely.Polygon) -> bool:
        return (view_px.contains(box) and not any(box.intersects(o) for o in shapes)
                and not any(box.intersects(c) for c in circles) and not any(box.intersects(t) for t in taken))

    for obstacle, shape in zip(scene.obstacles, shapes):
        seen = obstacle.polygon.intersection(view)
        if seen.is_empty:
            continue
        part = seen if isinstance(seen, shapely.Polygon) else max(getattr(seen, "geoms", [seen]), key=lambda g: g.area)
        inner = part.centroid
        if not part.contains(inner):             # a concave obstacle: the point farthest inside it
            from shapely.ops import polylabel
            inner = polylabel(part, tolerance=0.01)
        label = ax.annotate(obstacle.name, (inner.x, inner.y), xytext=(0, 0), textcoords="offset points",
                            ha="center", va="center", fontsize=7, color="white", zorder=2.6)
        fits = False
        for rotation in (0, 90):                 # a tall, narrow obstacle gets its name upright
            label.set_rotation(rotation)
            box = _box(label, renderer, pad=1.0)
            fits = shape.contains(box) and not any(box.intersects(c) for c in circles)
            if fits:
                break
        if fits:
            taken.append(box)
            continue
        label.set_rotation(0)
        label.set_color("0.1")
        label.set_bbox({"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "0.4",
                        "linewidth": 0.5, "alpha": 0.9})
        bx0, by0, bx1, by1 = seen.bounds
        anchors = [((bx0 + bx1) / 2, by1, 0, 4, "center", "bottom"), ((bx0 + bx1) / 2, by0, 0, -4, "center", "top"),
                   (bx1, (by0 + by1) / 2, 4, 0, "left", "center"), (bx0, (by0 + by1) / 2, -4, 0, "right", "center")]
        for k, (ax_, ay, dx, dy, ha, va) in enumerate([*anchors, anchors[0]]):
            label.xy = (ax_, ay)
            label.xyann = (dx, dy)
            label.set(horizontalalignment=ha, verticalalignment=va)
            box = _box(label, renderer, pad=3.0)
            if free(box) or k == len(anchors):
                break
        taken.append(box)
    for ann in boxed:
        taken.append(_settle(ann, _STEP_SPOTS, renderer, free))


def _steps_text(steps: Sequence[int]) -> str:
    """``"steps 0,1"``, ``"steps 3-6"`` (a run), ``"steps 1,4,5"``."""
    if len(steps) > 2 and steps == list(range(steps[0], steps[-1] + 1)):
        return f"steps {steps[0]}-{steps[-1]}"
    return "steps " + ",".join(str(i) for i in steps)


def still_steps(states: Sequence[StepState]) -> list[str]:
    """Why the plan has a step at which nothing moves, one line per such step: the next state
    is the same place for every arm and the payload (no action at that step, or actions that
    moved nothing).

    >>> s = StepState(robots={"r1": (0, 0)}, payload={"a": (0, 0), "b": (0, 5)})
    >>> still_steps([s, s, StepState(robots={"r1": (1, 0)}, payload={"a": (1, 0), "b": (1, 5)})])
    ['step 0 -> 1: the same place, no action (every arm waits)']
    """
    out = []
    for i, (a, b) in enumerate(zip(states, states[1:])):
        if dict(a.robots) == dict(b.robots) and dict(a.payload) == dict(b.payload):
            why = "no action (every arm waits)" if not a.actions else f"{', '.join(a.actions)} moves no arm"
            out.append(f"step {i} -> {i + 1}: the same place, {why}")
    return out

def _save(fig: Figure, path: Path) -> Path:
    # SVG keeps its text as text (searchable, editable) instead of glyph outlines
    with matplotlib.rc_context({"svg.fonttype": "none"}):
        fig.savefig(path, format=_format_of(path), dpi=150, bbox_inches="tight")
    return path


def plan_figure(scene: Scene, states: Sequence[StepState], violation: Violation | None = None, *,
                title: str | None = None) -> Figure:
    """The figure of `plot_plan`, unsaved (its axes and texts can be inspected)."""
    if not states:
        raise TrajectoryError("cannot plot an empty plan")
    fig = Figure(figsize=(8, 6))
    ax = fig.add_subplot()
    _draw_scene(ax, scene)
    boxed = _draw_states(ax, scene, states, paths=True)
    notes = still_steps(states)
    if violation is not None:
        i = violation.step
        a, b = states[min(i, len(states) - 1)], states[min(i + 1, len(states) - 1)]
        e1, e2 = scene.end_names
        region = swept_region_for_display(a.payload[e1], a.payload[e2], b.payload[e1], b.payload[e2])
        parts = [g for g in getattr(region, "geoms", [region])
                 if isinstance(g, shapely.Polygon) and not g.is_empty]
        for n, geom in enumerate(parts):
            ax.add_patch(PolygonPatch(shapely.get_coordinates(geom.exterior), closed=True,
                                      facecolor="gold", edgecolor="darkorange", alpha=0.45, zorder=2.5,
                                      label=f"payload sweep, step {i} -> {i + 1}" if n == 0 else None))
        for k, robot in enumerate(scene.robots):
            p, q = a.robots[robot.name], b.robots[robot.name]
            ax.plot([p[0], q[0]], [p[1], q[1]], color=_color(k), linewidth=3.5, alpha=0.5, zorder=4)
        ax.plot([violation.point[0]], [violation.point[1]], marker="X", markersize=16, color="crimson",
                markeredgecolor="white", zorder=7, linestyle="none",
                label=f"first violation ({violation.kind.value})")
    lines = ["\n".join(textwrap.wrap(violation.message, 110))] if violation is not None else []
    if lines or notes:
        fig.text(0.5, 0.005, "\n".join(lines + notes), ha="center", va="bottom",
                 fontsize=7.5, color="crimson" if violation is not None else "0.25")
    ax.set_title(title or plan_title(scene, len(states) - 1))
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    _place_labels(ax, scene, states, boxed)
    return fig


def plan_title(scene: Scene, length: int, source: str | None = None) -> str:
    """A plan picture's title: the scene's name (two scenes of one domain are told apart), the
    plan's length, and where it comes from (the domain file): ``payload with an island: plan of
    length 12 (payload.cp)``."""
    return f"{scene.name}: plan of length {length}" + (f" ({source})" if source else "")


def plot_plan(scene: Scene, states: Sequence[StepState], violation: Violation | None = None, *,
              path: str | Path, title: str | None = None) -> Path:
    """Draw a plan over the scene (like the paper's Fig. 2) and save it as PNG or SVG.

    With ``violation``, the motion from ``violation.step`` to the next state is highlighted:
    the payload's swept region shaded, the first contact crossed, the message printed. A step
    at which nothing moves is named under the plot with the reason (no action, or actions
    that moved no arm), and its circle carries a boxed label with every step drawn there.
    """
    out = Path(path)
    _format_of(out)
    return _save(plan_figure(scene, states, violation, title=title), out)


def execution_figure(scene: Scene, planned_paths: Mapping[str, npt.ArrayLike],
                     executed_paths: Mapping[str, npt.ArrayLike], *,
                     states: Sequence[StepState] | None = None, title: str | None = None,
                     payload_every: int = 5, timeline: RunTimeline | None = None) -> Figure:
    """The figure of `plot_execution`, unsaved (its axes and texts can be inspected)."""
    names = list(scene.robot_names)
    for name in [*planned_paths, *executed_paths]:
        if name not in names:
            raise TrajectoryError(f"cannot plot robot {name}: it is not in the scene")
    if timeline is None:
        fig = Figure(figsize=(8, 6))
        ax = fig.add_subplot()
    else:
        for b in timeline.bricks:
            if b.name not in names:
                raise TrajectoryError(f"cannot plot brick {b.name}: it is not a robot of the scene")
        cols = len(timeline.bricks)
        width = max(10.0, 5.6 * cols)
        rows_h = (6.0, 2.5, 1.9, 1.0 + 0.55 * cols)
        fig = Figure(figsize=(width, sum(rows_h) + 1.2), layout="constrained")
        grid = fig.add_gridspec(4, cols, height_ratios=rows_h)
        ax = fig.add_subplot(grid[0, :])
        colors = [_color(names.index(b.name)) for b in timeline.bricks]
        specs = [grid[r, c] for c in range(cols) for r in (1, 2)]
        add_time_panels(fig, specs, grid[3, :], timeline, colors, motor_roles(scene))
    _draw_scene(ax, scene)
    boxed = _draw_states(ax, scene, states, paths=False) if states else []
    for k, name in enumerate(names):
        color = _color(k)
        if name in executed_paths:
            pts = np.asarray(executed_paths[name], dtype=float).reshape(-1, 2)
            ax.plot(pts[:, 0], pts[:, 1], color=color, linewidth=2.6, alpha=0.75, zorder=4,
                    solid_capstyle="round", label=f"{name} executed")
        if name in planned_paths:   # on top, thin and dark: it shows where the executed path lies on it
            pts = np.asarray(planned_paths[name], dtype=float).reshape(-1, 2)
            ax.plot(pts[:, 0], pts[:, 1], color=_darker(color), linewidth=0.9, linestyle=(0, (4, 3)),
                    zorder=4.5, label=f"{name} planned (dashed, on top)")
    holders: list[str] = []
    if states:
        holders = [h for h in (states[0].holder(e) for e in scene.end_names) if h is not None]
    elif len(names) >= 2:
        holders = names[:2]
    if len(holders) == 2 and all(h in executed_paths for h in holders):
        p = np.asarray(executed_paths[holders[0]], dtype=float).reshape(-1, 2)
        q = np.asarray(executed_paths[holders[1]], dtype=float).reshape(-1, 2)
        n = min(len(p), len(q))
        stride = max(1, int(payload_every))
        for j, k in enumerate(list(range(0, n, stride)) + ([n - 1] if n and (n - 1) % stride else [])):
            ax.plot([p[k, 0], q[k, 0]], [p[k, 1], q[k, 1]], color=PAYLOAD_COLOR, linewidth=0.6,
                    alpha=0.7, zorder=3, label="payload (executed)" if j == 0 else None)
    ax.set_title(title or f"{scene.name}: planned and executed paths")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    _place_labels(ax, scene, states or [], boxed)
    return fig


def plot_execution(scene: Scene, planned_paths: Mapping[str, npt.ArrayLike],
                   executed_paths: Mapping[str, npt.ArrayLike], path: str | Path, *,
                   states: Sequence[StepState] | None = None, title: str | None = None,
                   payload_every: int = 5, timeline: RunTimeline | None = None) -> Path:
    """Draw planned against executed end-effector paths (like the paper's Fig. 5).

    ``planned_paths`` and ``executed_paths`` map robot names to arrays of shape (n, 2).
    With ``states``, the plan's steps are drawn as labelled circles and thick payload lines.
    Thin green payload segments join the executed positions of the two robots holding the
    payload's ends (at the first state, or the first two robots without ``states``) every
    ``payload_every`` samples. With ``timeline`` (the run over time, `RunTimeline`), panels
    below show per brick its motor angles and tracking error against time, and one row per
    brick its phases, its start interval and its events (`trajectory.time_panels`).
    """
    out = Path(path)
    _format_of(out)
    return _save(execution_figure(scene, planned_paths, executed_paths, states=states, title=title,
                                  payload_every=payload_every, timeline=timeline), out)
