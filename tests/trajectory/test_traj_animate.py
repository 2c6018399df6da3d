"""Animations: GIF files Pillow opens, with the frames asked for, the plan alone or planned
against executed, and an online run's cycles; bad requests refused before any work."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from test_traj_plots import timeline_of
from traj_helpers import CLEAN_PAYLOAD_PLAN, plan

import trajectory.animate as animate_module
from trajectory import (
    CycleFrame,
    Scene,
    TrajectoryError,
    animate_cycles,
    animate_run,
    animation_problem,
    build_trajectory,
)


@pytest.fixture(scope="module")
def traj(payload_scene: Scene):
    return build_trajectory(payload_scene, plan(*CLEAN_PAYLOAD_PLAN), points_per_step=4, step_time_s=0.4)


def frames_of(path: Path) -> list[np.ndarray]:
    with Image.open(path) as im:
        assert im.format == "GIF"
        out = []
        for k in range(im.n_frames):
            im.seek(k)
            out.append(np.asarray(im.convert("RGB")))
        return out


def test_a_plan_animation_has_the_frames_asked_for(payload_scene: Scene, traj, tmp_path: Path) -> None:
    seen: list[tuple[int, int]] = []
    out = animate_run(payload_scene, traj, tmp_path / "plan.gif", max_frames=6, dpi=30,
                      on_progress=lambda done, total: seen.append((done, total)))
    frames = frames_of(out)
    assert len(frames) == 6 and seen == [(k, 6) for k in range(1, 7)]
    assert frames[0].shape[1] == 8 * 30                     # 8 inches wide at 30 dpi
    assert not np.array_equal(frames[0], frames[-1])        # the arms moved
    with Image.open(out) as im:
        assert im.info["duration"] > 0
    # every tick when there are fewer than max_frames
    assert len(frames_of(animate_run(payload_scene, traj, tmp_path / "all.gif", dpi=20))) == traj.ticks


def test_executed_over_planned_shows_the_difference(payload_scene: Scene, traj, tmp_path: Path) -> None:
    planned = frames_of(animate_run(payload_scene, traj, tmp_path / "p.gif", max_frames=4, dpi=30))
    timeline = timeline_of(traj, late_s=0.2)
    executed = frames_of(animate_run(payload_scene, traj, tmp_path / "e.gif", timeline=timeline, max_frames=4,
                                     dpi=30))
    assert len(executed) == 4 and executed[0].shape == planned[0].shape
    assert any(not np.array_equal(a, b) for a, b in zip(planned, executed))


def test_the_executed_arm_lags_by_the_brick_start(payload_scene: Scene, traj, tmp_path: Path) -> None:
    timeline = timeline_of(traj, late_s=2 * traj.tick_ms / 1000)    # r2 two ticks late
    n = traj.ticks
    ticks = np.arange(n + 2)
    r1, r2 = traj.robots
    s1, _ = animate_module._executed_joints(r1, timeline, ticks)
    s2, th2 = animate_module._executed_joints(r2, timeline, ticks)
    s_own, _ = r2.joints_from_motor_deg(timeline.brick("r2").measured_deg)
    assert s2[5] == pytest.approx(s_own[3])                 # at common tick 5 it is at its own tick 3
    assert s2[n + 1] == pytest.approx(s_own[n - 1])         # and it ends two ticks after r1
    assert s2[0] == pytest.approx(s_own[0])                 # before its start: where it stood
    assert np.isnan(s1[n:]).all() and np.isfinite(s1[:n]).all()
    assert len(frames_of(animate_run(payload_scene, traj, tmp_path / "late.gif", timeline=timeline,
                                     dpi=20))) == n + 2
    stopped = timeline_of(traj, stop_at=10)
    s, th = animate_module._executed_joints(r1, stopped, np.arange(n))
    assert np.isfinite(s[:10]).all() and np.isnan(s[10:]).all() and np.isnan(th[10:]).all()


def test_an_online_run_replays_cycle_by_cycle(payload_scene: Scene, tmp_path: Path) -> None:
    frames = [CycleFrame(0, 0.0, {"xpos(r1)": "0"}, {"r1": (0, 0), "r2": (0, 5), "pl1": (0, 0), "pl2": (0, 5)},
                         ("executed: move(r1,right)",)),
              CycleFrame(1, 1.5, {"xpos(r1)": "1"}, {"r1": (1, 0), "r2": (1, 5), "pl1": (1, 0), "pl2": (1, 5)},
                         ("RE-PLANNED (fault)",), replanned=True),
              CycleFrame(1, 2.0, {"xpos(r1)": "1"}, {"r1": (1, 0), "r2": (1, 5)}, ("the run ended",), ended=True)]
    arms = frames_of(animate_cycles(frames, tmp_path / "arms.gif", scene=payload_scene, dpi=30))
    table = frames_of(animate_cycles(frames, tmp_path / "table.gif", dpi=30))
    assert len(arms) == len(table) == 3
    assert not np.array_equal(arms[0], arms[1]) and not np.array_equal(arms[0], table[0])
    assert len(frames_of(animate_cycles(frames * 10, tmp_path / "few.gif", dpi=20, max_frames=5))) == 5


def test_bad_requests_are_refused_before_any_work(payload_scene: Scene, traj, tmp_path: Path, monkeypatch) -> None:
    assert animation_problem("a.GIF") is None
    assert animation_problem("a.png") == "use a .gif or .mp4 file name"
    monkeypatch.setattr(animate_module.animation.writers, "is_available", lambda name: False)
    assert "needs ffmpeg, which is not installed" in (animation_problem("a.mp4") or "")
    with pytest.raises(TrajectoryError, match="cannot animate to .*a.mp4: an .mp4 needs ffmpeg"):
        animate_run(payload_scene, traj, tmp_path / "a.mp4")
    with pytest.raises(TrajectoryError, match="use a .gif or .mp4"):
        animate_run(payload_scene, traj, tmp_path / "a.webm")
    with pytest.raises(TrajectoryError, match="max_frames must be at least 1"):
        animate_run(payload_scene, traj, tmp_path / "a.gif", max_frames=0)
    with pytest.raises(TrajectoryError, match="dpi must be from 10 to 600"):
        animate_run(payload_scene, traj, tmp_path / "a.gif", dpi=5)
    with pytest.raises(TrajectoryError, match="no cycle to replay"):
        animate_cycles([], tmp_path / "a.gif")
    assert not list(tmp_path.iterdir())     # nothing written


def test_an_mp4_is_written_by_ffmpeg(payload_scene: Scene, traj, tmp_path: Path) -> None:
    if not animate_module.animation.writers.is_available("ffmpeg"):
        # CI installs ffmpeg (.ci/run) and sets CPLUS_REQUIRE_FFMPEG: there it must not skip
        assert not os.environ.get("CPLUS_REQUIRE_FFMPEG"), "ffmpeg is not installed"
        pytest.skip("ffmpeg is not installed")
    out = animate_run(payload_scene, traj, tmp_path / "plan.mp4", max_frames=5, dpi=25)
    data = out.read_bytes()
    assert data[4:8] == b"ftyp" and len(data) > 1000          # an MP4 container
    assert [p.name for p in tmp_path.iterdir()] == ["plan.mp4"]   # nothing left beside it


def test_a_robot_the_scene_lacks_is_refused(payload_scene: Scene, traj, tmp_path: Path) -> None:
    other = type(traj)(traj.tick_ms, traj.step_time_s, traj.points_per_step, traj.plan_length,
                       (dataclasses.replace(traj.robots[0], name="r7"),), traj.source)
    with pytest.raises(TrajectoryError, match="cannot animate robot r7: it is not in the scene"):
        animate_run(payload_scene, other, tmp_path / "a.gif")


# --------------------------------------------------------------------------- a replay's figure

def _delivery_frames(n: int = 4) -> list[CycleFrame]:
    """Cycles of a delivery run: the letters in the order the log lists them (1, 3, 2, 4)."""
    out = []
    for k in range(n):
        state = {"atLandmark": str(1 + k % 3), "letter(1)": "true" if k else "false", "letter(3)": "true",
                 "letter(2)": "false", "letter(10)": "false", "letter(4)": "false", "trayUp": "true"}
        out.append(CycleFrame(k, 1.5 * k, state, actions=("follow",) if k % 2 else ("turn", "lowerTray", "x", "y")))
    return out


def _table(fig):
    (ax,) = [a for a in fig.axes if a.tables]
    return ax, ax.tables[0]


def test_a_replay_table_has_an_actions_row_then_the_fluents_in_order() -> None:
    fig = animate_module.cycles_figure(_delivery_frames())
    _, table = _table(fig)
    cells = table.get_celld()
    labels = [cells[r, -1].get_text().get_text() for r in range(1, 9)]
    assert labels == [animate_module.ACTIONS_ROW, "atLandmark", "letter(1)", "letter(2)", "letter(3)", "letter(4)",
                      "letter(10)", "trayUp"]
    assert [cells[1, c].get_text().get_text() for c in range(4)] == ["turn\nlowerTray\n+2 more", "follow",
                                                                     "turn\nlowerTray\n+2 more", "follow"]
    assert animate_module.table_rows(_delivery_frames())[0][2:6] == ["letter(2)", "letter(3)", "letter(4)",
                                                                     "letter(10)"]


@pytest.mark.parametrize("cycles", [2, 10])
def test_a_replay_table_fills_its_axes(cycles: int) -> None:
    """No empty bottom quarter: the table reaches the bottom of its axes, whatever the rows."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    fig = animate_module.cycles_figure(_delivery_frames(cycles))
    renderer = FigureCanvasAgg(fig).get_renderer()
    ax, table = _table(fig)
    box, area = table.get_window_extent(renderer), ax.get_window_extent(renderer)
    assert box.y0 <= area.y0 + 0.02 * area.height and box.y1 >= area.y1 - 0.02 * area.height


def test_a_replay_shows_the_replan_star_and_the_failure_cross_at_one_place(payload_scene: Scene) -> None:
    """The cycle that failed left the arms where the next one re-planned: both marks show there."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import to_rgb
    at = {"r1": (4.0, 0.0), "r2": (4.0, 5.0), "pl1": (4.0, 0.0), "pl2": (4.0, 5.0)}
    frames = [CycleFrame(0, 0.0, {}, {"r1": (0.0, 0.0), "r2": (0.0, 5.0)}, failed=True),
              CycleFrame(4, 4.0, {}, at, replanned=True),
              CycleFrame(6, 6.0, {}, {"r1": (6.0, 2.0), "r2": (6.0, 7.0)})]
    fig = animate_module.cycles_figure(frames, scene=payload_scene)
    (ax,) = [a for a in fig.axes if a.get_legend() is not None]
    marks = {line.get_label(): line for line in ax.get_lines() if line.get_label() in ("re-planned here",
                                                                                       "failure here")}
    assert [tuple(p) for p in marks["failure here"].get_xydata()] == [(4.0, 0.0)]   # where cycle 0 left the arms
    assert [tuple(p) for p in marks["re-planned here"].get_xydata()] == [(4.0, 0.0)]
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    image = np.asarray(canvas.buffer_rgba())[:, :, :3].astype(float) / 255
    x, y = ax.transData.transform((4.0, 0.0))
    row, col = int(image.shape[0] - y), int(x)
    window = image[row - 20:row + 21, col - 20:col + 21].reshape(-1, 3)

    def seen(color: str) -> int:
        return int((np.abs(window - np.array(to_rgb(color))).max(axis=1) < 0.08).sum())
    assert seen("darkorange") > 20 and seen("crimson") > 5
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert legend[-3:] == ["several steps in one cycle", "re-planned here", "failure here"]
