"""Pictures: real PNG and SVG files with the plan, and the violation highlighted."""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread
from traj_helpers import CLEAN_PAYLOAD_PLAN, FIRST_PAYLOAD_PLAN, plan

from trajectory import Scene, TrajectoryError, build_trajectory, first_violation, plot_execution, plot_plan

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
