"""Pictures: real PNG and SVG files with the plan, and the violation highlighted; the execution
with its panels over time."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread
from traj_helpers import CLEAN_PAYLOAD_PLAN, FIRST_PAYLOAD_PLAN, carried, plan

from trajectory import (
    BrickTimeline,
    RunTimeline,
    Scene,
    TrajectoryError,
    build_trajectory,
    execution_figure,
    first_violation,
    plan_figure,
    plot_execution,
    plot_plan,
)
from trajectory.plots import still_steps

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def svg_text(path: Path) -> str:
    root = ET.parse(path).getroot()  # well-formed XML
    assert root.tag.endswith("svg")
    return " ".join(t.text or "" for t in root.iter() if t.tag.endswith("text"))


def test_plan_png_has_content(payload_scene: Scene, tmp_path: Path) -> None:
    out = plot_plan(payload_scene, plan(*CLEAN_PAYLOAD_PLAN), path=tmp_path / "plan.png")
    assert out.read_bytes()[:8] == PNG_MAGIC
    img = imread(out)
    assert img.shape[0] > 300 and img.shape[1] > 300
    rgb = img[..., :3]
    # black obstacles, blue and red robots, green payload are all on the picture
    assert (rgb.max(axis=2) < 0.2).sum() > 500
    assert ((rgb[..., 2] > 0.6) & (rgb[..., 0] < 0.3)).sum() > 50     # tab:blue
    assert ((rgb[..., 0] > 0.7) & (rgb[..., 1] < 0.3)).sum() > 50     # tab:red
    assert ((rgb[..., 1] > 0.5) & (rgb[..., 0] < 0.3) & (rgb[..., 2] < 0.3)).sum() > 50  # tab:green


def test_violation_is_highlighted(payload_scene: Scene, tmp_path: Path) -> None:
    states = plan(*FIRST_PAYLOAD_PLAN)
    v = first_violation(payload_scene, states)
    assert v is not None
    plain = plot_plan(payload_scene, states, path=tmp_path / "plain.svg")
    marked = plot_plan(payload_scene, states, v, path=tmp_path / "marked.svg")
    text = svg_text(marked)
    assert "first violation (payload-length)" in text
    assert "payload sweep, step 3 -> 4" in text
    assert "reaching 22.5" in text
    assert "first violation" not in svg_text(plain)
    # step labels 0..9 are drawn at the circles ("0,1" where the arms wait a step)
    labels = set(re.split(r"[\s,]+", svg_text(plain)))
    assert all(str(i) in labels for i in range(len(states)))
    png_plain = imread(plot_plan(payload_scene, states, path=tmp_path / "plain.png"))
    png_marked = imread(plot_plan(payload_scene, states, v, path=tmp_path / "marked.png"))
    assert png_plain.shape != png_marked.shape or not np.array_equal(png_plain, png_marked)


def test_execution_plot(payload_scene: Scene, tmp_path: Path) -> None:
    states = plan(*CLEAN_PAYLOAD_PLAN)
    traj = build_trajectory(payload_scene, states, points_per_step=5, step_time_s=0.5)
    planned = traj.planned_paths()
    rng = np.random.default_rng(0)
    executed = {}
    for r in traj.robots:
        logged = r.setpoints_deg + rng.integers(-6, 7, size=r.setpoints_deg.shape)
        executed[r.name] = np.column_stack(r.xy_from_motor_deg(logged))
    out = plot_execution(payload_scene, planned, executed, tmp_path / "exec.svg", states=states)
    text = svg_text(out)
    for label in ("r1 planned", "r1 executed", "r2 planned", "r2 executed", "payload (executed)"):
        assert label in text
    png = plot_execution(payload_scene, planned, executed, tmp_path / "exec.png")
    assert png.read_bytes()[:8] == PNG_MAGIC and png.stat().st_size > 10_000


def test_bad_requests(payload_scene: Scene, tmp_path: Path) -> None:
    states = plan(*CLEAN_PAYLOAD_PLAN)
    with pytest.raises(TrajectoryError, match="use a .png or .svg file name"):
        plot_plan(payload_scene, states, path=tmp_path / "plan.jpg")
    with pytest.raises(TrajectoryError, match="robot r7"):
        plot_execution(payload_scene, {"r7": [(0, 0)]}, {}, tmp_path / "x.png")
    with pytest.raises(TrajectoryError, match="empty plan"):
        plot_plan(payload_scene, [], path=tmp_path / "e.png")
    assert not list(tmp_path.iterdir())  # nothing half-written


def timeline_of(traj, *, late_s: float = 0.0, stop_at: int | None = None, events=()) -> RunTimeline:
    """A run of ``traj``: each brick a little off its setpoints, r2 starting ``late_s`` later,
    both measured up to tick ``stop_at`` (all ticks without it)."""
    rng = np.random.default_rng(1)
    bricks = []
    for k, r in enumerate(traj.robots):
        measured = r.setpoints_deg + rng.integers(-3, 4, size=r.setpoints_deg.shape)
        start = 1.0 + (late_s if k == 1 else 0.0)
        bricks.append(BrickTimeline(r.name, r.ports, traj.tick_ms / 1000, r.setpoints_deg,
                                    measured[:stop_at] if stop_at is not None else measured,
                                    start_s=(start - 0.01, start + 0.01),
                                    events=((0.2, "link ok", ""), (0.5, "upload verified", ""), *events),
                                    reached="done" if stop_at is None else "stopped"))
    stopped = None if stop_at is None else (1.0 + stop_at * traj.tick_ms / 1000, "brick r2: link lost")
    return RunTimeline(tuple(bricks), stopped, (late_s, max(0.0, late_s - 0.02), late_s + 0.02))


def test_the_execution_picture_shows_the_run_over_time(payload_scene: Scene, tmp_path: Path) -> None:
    states = plan(*CLEAN_PAYLOAD_PLAN)
    traj = build_trajectory(payload_scene, states, points_per_step=5, step_time_s=0.5)
    timeline = timeline_of(traj, late_s=0.04, events=((0.3, "timeout", "READ attempt 1"),))
    fig = execution_figure(payload_scene, traj.planned_paths(), traj.planned_paths(), timeline=timeline)
    titles = [ax.get_title() for ax in fig.axes]
    for name in ("r1", "r2"):
        assert f"{name}: motor angles (setpoint dashed, measured solid)" in titles
        assert f"{name}: tracking error (measured - setpoint)" in titles
    bricks = next(ax for ax in fig.axes if ax.get_title().startswith("bricks over time"))
    assert "start skew 40 ms (between 20 and 60 ms)" in bricks.get_title()
    texts = {t.get_text() for t in bricks.texts}
    assert "timeout" in texts and "start 0.990-1.010 s" in texts
    error = next(ax for ax in fig.axes if ax.get_title() == "r1: tracking error (measured - setpoint)")
    legend = [t.get_text() for t in error.get_legend().get_texts()]
    worst = np.abs(timeline.brick("r1").error_deg).max(axis=0)
    assert legend[0].startswith(f"A (carriage wheel): max {worst[0]:.0f}°")
    # r2 started 40 ms later: its curves are shifted by that much on the common time axis
    deg = {ax.get_title().split(":")[0]: ax for ax in fig.axes if "motor angles" in ax.get_title()}
    t1, t2 = (deg[n].lines[1].get_xdata()[0] for n in ("r1", "r2"))
    assert t2 - t1 == pytest.approx(0.04)
    png = plot_execution(payload_scene, traj.planned_paths(), traj.planned_paths(), tmp_path / "exec.png",
                         timeline=timeline)
    assert imread(png).shape[0] > 1500     # the panels are below the paths, not squeezed into them
    phases = [t.get_text() for t in bricks.get_legend().get_texts()]
    assert phases == ["connect", "upload", "waiting for the other bricks (prepared one at a time)",
                      "run (the robot's colour)"]


def test_an_incomplete_run_marks_where_it_stopped(payload_scene: Scene) -> None:
    traj = build_trajectory(payload_scene, plan(*CLEAN_PAYLOAD_PLAN), points_per_step=5, step_time_s=0.5)
    timeline = timeline_of(traj, stop_at=12)
    fig = execution_figure(payload_scene, traj.planned_paths(), {}, timeline=timeline)
    bricks = next(ax for ax in fig.axes if ax.get_title().startswith("bricks over time"))
    assert "stopped: brick r2: link lost" in {t.get_text() for t in bricks.texts}
    stop = 1.0 + 12 * traj.tick_ms / 1000
    for ax in fig.axes[1:]:   # every time panel has the stop line
        assert any(list(line.get_xdata()) == [stop, stop] for line in ax.lines), ax.get_title()
    assert timeline.brick("r1").measured_ticks == 12
    assert np.isnan(timeline.brick("r1").error_deg[12:]).all()


def test_a_brick_that_never_started_says_so(payload_scene: Scene) -> None:
    traj = build_trajectory(payload_scene, plan(*CLEAN_PAYLOAD_PLAN), points_per_step=5, step_time_s=0.5)
    r1, r2 = traj.robots
    timeline = RunTimeline((BrickTimeline("r1", r1.ports, 0.1, r1.setpoints_deg, [], reached="connect"),
                            BrickTimeline("r2", r2.ports, 0.1, r2.setpoints_deg, [], reached="connect")),
                           (0.4, "brick r1 is running 'tetris.rxe'"))
    fig = execution_figure(payload_scene, traj.planned_paths(), {}, timeline=timeline)
    texts = {t.get_text() for ax in fig.axes for t in ax.texts}
    assert "r1 never started (reached: connect)" in texts


def test_bad_timelines_are_refused(payload_scene: Scene) -> None:
    with pytest.raises(TrajectoryError, match="one value per motor"):
        BrickTimeline("r1", ("A", "B"), 0.1, [[0, 0]], [[0]])
    with pytest.raises(TrajectoryError, match="2 measured rows for 1 ticks"):
        BrickTimeline("r1", ("A",), 0.1, [[0]], [[0], [1]])
    with pytest.raises(TrajectoryError, match="positive time"):
        BrickTimeline("r1", ("A",), 0.0, [[0]], [[0]])
    with pytest.raises(TrajectoryError, match="names a brick twice"):
        RunTimeline((BrickTimeline("r1", ("A",), 0.1, [[0]], [[0]]),) * 2)
    with pytest.raises(TrajectoryError, match="brick r9: it is not a robot of the scene"):
        execution_figure(payload_scene, {}, {}, timeline=RunTimeline((BrickTimeline("r9", ("A",), 0.1, [[0]], [[0]]),)))


def test_steps_at_one_place_are_named_with_the_reason(payload_scene: Scene) -> None:
    states = plan(*CLEAN_PAYLOAD_PLAN)     # steps 0 and 1 are the same state: nothing happens at step 0
    fig = plan_figure(payload_scene, states)
    ax = fig.axes[0]
    boxed = [t for t in ax.texts if t.get_bbox_patch() is not None and t.get_text().startswith("steps")]
    assert sorted(t.get_text() for t in boxed) == ["steps 0,1", "steps 0,1", "steps 8,9"]   # r1 waits at step 8
    assert all(t.get_fontsize() >= 8 for t in boxed)
    assert "step 0 -> 1: the same place, no action (every arm waits)" in [t.get_text() for t in fig.texts]
    grasp = [carried((0, 0), (0, 5), ["grasp(r1)"]), carried((0, 0), (0, 5)), carried((1, 0), (1, 5))]
    assert still_steps(grasp) == ["step 0 -> 1: the same place, grasp(r1) moves no arm"]
    assert still_steps(plan(((0, 0), (0, 5)), ((1, 0), (1, 5)))) == []


def test_a_motor_that_stops_following_is_shaded_and_named(payload_scene: Scene) -> None:
    """A stalled motor (held still while its setpoint moves on) is marked where its error is
    beyond the online monitor's threshold, and only there."""
    from cplus.robot.online.payload_monitor import TRACKING_THRESHOLD_DEG
    from trajectory.timeline import STALL_ERROR_DEG
    assert STALL_ERROR_DEG == TRACKING_THRESHOLD_DEG
    traj = build_trajectory(payload_scene, plan(*CLEAN_PAYLOAD_PLAN), points_per_step=5, step_time_s=0.5)
    clean = timeline_of(traj)
    r1, r2 = clean.bricks
    held = r1.measured_deg.copy()
    a = int(np.argmax(np.abs(np.diff(r1.setpoint_deg[:, 0])) > 0))   # A's first move
    held[a:, 0] = held[a, 0]                                          # A stops there for good
    stalled = BrickTimeline(r1.name, r1.ports, r1.tick_s, r1.setpoint_deg, held, start_s=r1.start_s,
                            events=r1.events)
    spans = stalled.stall_spans()
    assert spans and {p for p, _, _ in spans} == {"A"}
    first = int(np.argmax(np.abs(held[:, 0] - r1.setpoint_deg[:, 0]) > STALL_ERROR_DEG))
    assert spans[0][1] == pytest.approx(stalled.tick_end_s[first] - r1.tick_s)
    assert r2.stall_spans() == [] and r1.stall_spans() == []
    fig = execution_figure(payload_scene, traj.planned_paths(), traj.planned_paths(),
                           timeline=RunTimeline((stalled, r2), None, clean.skew_s))
    err = {ax.get_title(): ax for ax in fig.axes}
    r1_err, r2_err = (err[f"{n}: tracking error (measured - setpoint)"] for n in ("r1", "r2"))
    assert "A not following" in {t.get_text() for t in r1_err.texts}
    assert any(t.get_text().startswith("not following (|error| > 30°)") for t in r1_err.get_legend().get_texts())
    assert not any("not following" in t.get_text() for t in r2_err.texts)


# --------------------------------------------------------------------------- what a reviewer reads without the source

ISLAND_PLAN = [((0, 0), (0, 5)), ((0, 0), (0, 5)), ((0, 1), (1, 6)), ((1, 2), (2, 7)), ((2, 3), (5, 7)),
               ((2, 3), (6, 6)), ((2, 4), (7, 5)), ((3, 4), (8, 5)), ((4, 3), (8, 6)), ((5, 2), (8, 6)),
               ((8, 2), (9, 7)), ((9, 1), (10, 6)), ((10, 0), (10, 5))]
"""The plan the refinement finds on the island scene: r1 waits at (2, 3), next to the island, at steps 4 and 5."""


@pytest.fixture(scope="module")
def island_scene() -> Scene:
    from traj_helpers import REPO

    from trajectory import load_scene
    return load_scene(REPO / "domains" / "payload" / "scenes" / "island.toml")


def _display_shapes(fig, ax):
    import shapely
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    obstacles = [shapely.Polygon(p.get_verts()) for p in ax.patches if p.get_label() != "" and
                 p.get_facecolor()[:3] == pytest.approx((0.15, 0.15, 0.15))] or \
                [shapely.Polygon(p.get_verts()) for p in ax.patches]

    def box(text):
        patch = text.get_bbox_patch()
        bb = (patch if patch is not None else text).get_window_extent(renderer)
        return shapely.box(bb.x0, bb.y0, bb.x1, bb.y1)
    return obstacles, box


@pytest.mark.parametrize("scene_name, states", [("payload", CLEAN_PAYLOAD_PLAN), ("island", ISLAND_PLAN)])
def test_a_plan_picture_names_its_obstacles_and_keeps_labels_off_them(payload_scene, island_scene, scene_name, states):
    scene = payload_scene if scene_name == "payload" else island_scene
    fig = plan_figure(scene, plan(*states))
    ax = fig.axes[0]
    texts = {t.get_text(): t for t in ax.texts}
    assert {o.name for o in scene.obstacles} <= set(texts)
    obstacles, box = _display_shapes(fig, ax)
    assert len(obstacles) == len(scene.obstacles)
    boxed = [t for t in ax.texts if t.get_text().startswith("steps")]
    assert boxed and not any(box(t).intersects(o) for t in boxed for o in obstacles)
    for k, t in enumerate(boxed):                           # nor on each other
        assert not any(box(t).intersects(box(u)) for u in boxed[k + 1:])
    for o, shape in zip(scene.obstacles, obstacles):        # a name inside its obstacle, or off every obstacle
        name = box(texts[o.name])
        assert shape.contains(name) or not any(name.intersects(s) for s in obstacles)
    assert texts["low wall"].get_rotation() == 90 and texts["post"].get_rotation() == 0
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend[:3] == ["grid points (the plan's positions)", "grid bounds", "obstacles"]
    assert ax.get_title() == f"{scene.name}: plan of length {len(states) - 1}"


def test_a_plan_s_title_names_its_scene_and_domain(island_scene, tmp_path):
    """The island plan is no longer titled like the shipped one."""
    from traj_helpers import REPO

    from cplus.robot.offline import RobotTask, export_plan
    domain = REPO / "domains" / "payload" / "payload.cp"
    task = RobotTask.load(str(domain), str(REPO / "domains" / "payload" / "scenes" / "island.toml"))
    (out,) = export_plan(task, plan(*ISLAND_PLAN), None, domain_path=str(domain), plot=str(tmp_path / "plan.svg"))
    assert "payload with an island: plan of length 12 (payload.cp)" in svg_text(Path(out))


def test_the_execution_picture_says_which_motor_is_what_and_shows_both_wheels(payload_scene: Scene) -> None:
    states = plan(*CLEAN_PAYLOAD_PLAN)
    traj = build_trajectory(payload_scene, states, points_per_step=5, step_time_s=0.5)
    clean = timeline_of(traj)
    r1, r2 = clean.bricks
    wheels = r1.measured_deg.copy()
    wheels[:, 1] = wheels[:, 0]                              # A and B, the carriage's wheels, turn alike
    alike = RunTimeline((BrickTimeline(r1.name, r1.ports, r1.tick_s, r1.setpoint_deg, wheels, start_s=r1.start_s,
                                       events=r1.events), r2), None, clean.skew_s, clock="simulated clock")
    fig = execution_figure(payload_scene, traj.planned_paths(), traj.planned_paths(), timeline=alike)
    panels = {ax.get_title(): ax for ax in fig.axes}
    angles = panels["r1: motor angles (setpoint dashed, measured solid)"]
    labels = [t.get_text() for t in angles.get_legend().get_texts()]
    assert labels == ["A (carriage wheel)", "B (carriage wheel, over A: the same curve)", "C (arm)", "setpoints"]
    a, b = (line for line in angles.get_lines() if line.get_label().startswith(("A ", "B ")))
    assert a.get_linewidth() > 2 * b.get_linewidth() and b.get_zorder() >= a.get_zorder()   # both show
    setpoints = [line for line in angles.get_lines() if line.get_linestyle() not in ("-", "None")]
    assert setpoints and all(s.get_zorder() > a.get_zorder() for s in setpoints)          # dashes over the curves
    error = panels["r2: tracking error (measured - setpoint)"]
    assert [t.get_text().split(":")[0] for t in error.get_legend().get_texts()] == [
        "A (carriage wheel)", "B (carriage wheel)", "C (arm)"]
    assert error.get_xlabel() == "time (s, simulated clock)"
    bricks = next(ax for ax in fig.axes if ax.get_title().startswith("bricks over time"))
    assert bricks.get_xlabel() == "time (s, simulated clock, from the start of the execution)"
    paths = fig.axes[0]
    by_label = {line.get_label(): line for line in paths.get_lines()}
    for name in ("r1", "r2"):         # the planned path is drawn over the executed one, thin and dark
        planned, executed = by_label[f"{name} planned (dashed, on top)"], by_label[f"{name} executed"]
        assert planned.get_zorder() > executed.get_zorder() and planned.get_linewidth() < executed.get_linewidth()
    plain = execution_figure(payload_scene, traj.planned_paths(), {}, timeline=clean)
    assert any(ax.get_xlabel() == "time (s, PC clock)" for ax in plain.axes)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    for title, ax in panels.items():         # a legend lies above every curve of its panel, hiding none
        if "motor angles" in title or "tracking error" in title:
            legend = ax.get_legend().get_window_extent(canvas.get_renderer())
            tops = [ax.transData.transform((0, np.nanmax(line.get_ydata())))[1] for line in ax.get_lines()
                    if len(line.get_ydata()) and np.isfinite(np.asarray(line.get_ydata(), dtype=float)).any()]
            assert tops and legend.y0 >= max(tops), title


def test_every_phase_of_a_brick_shows_and_a_wait_is_named(payload_scene: Scene) -> None:
    """Homing takes 20 ms of a 10 s run: its bar is drawn wide enough to see and its legend says
    how long it took; the time a brick waits while the other is uploaded is a phase of its own."""
    traj = build_trajectory(payload_scene, plan(*CLEAN_PAYLOAD_PLAN), points_per_step=5, step_time_s=0.5)
    events = ((0.2, "link ok", ""), (0.5, "upload verified", ""), (0.8, "homing", ""), (0.82, "ready", ""),
              (0.83, "start sent", ""))
    bricks = tuple(BrickTimeline(r.name, r.ports, traj.tick_ms / 1000, r.setpoints_deg, r.setpoints_deg,
                                 start_s=(0.99, 1.01), events=events) for r in traj.robots)
    fig = execution_figure(payload_scene, traj.planned_paths(), {}, timeline=RunTimeline(bricks))
    panel = next(ax for ax in fig.axes if ax.get_title().startswith("bricks over time"))
    legend = [t.get_text() for t in panel.get_legend().get_texts()]
    assert "homing (20 ms: drawn wider)" in legend
    assert "waiting for the other bricks (prepared one at a time)" in legend
    lo, hi = panel.get_xlim()
    from matplotlib.colors import to_rgba
    homing = next(p for p in panel.get_legend().get_patches() if p.get_label().startswith("homing")).get_facecolor()
    widths = [bars.get_datalim(panel.transData).width for bars in panel.collections     # one bar each
              if tuple(bars.get_facecolor()[0]) == pytest.approx(to_rgba(homing))]
    assert len(widths) == 2 and min(widths) >= 0.007 * (hi - lo) > 0.02


@pytest.mark.parametrize("argv, clock", [
    ([], "simulated clock"),                                   # emulated bricks on simulated time
    (["--time-scale", "2"], "PC clock"),
    (["--brick", "r1=/dev/rfcomm0", "--brick", "r2=/dev/rfcomm1"], "PC clock"),
])
def test_the_time_axes_name_the_clock_the_run_was_on(argv, clock):
    from cplus.cli.execute import build_parser, clock_of
    assert clock_of(build_parser().parse_args(["t.json", *argv])) == clock
