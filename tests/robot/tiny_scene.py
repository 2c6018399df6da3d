"""The scene of ``tiny.cp`` with given obstacles: r1 below the grid reaches y <= 1.5, r2 above
it y >= 1.5, and the payload (length 2) is held by both. The scene is stricter than the
domain's grid laws: its squared length must stay in [3.4, 4.6] (the domain allows [3, 5])."""
from __future__ import annotations

from pathlib import Path

DOMAIN = Path(__file__).with_name("tiny.cp")

_ROBOT = """
[robots.{name}]
rail_origin = [0.0, {rail_y}]
rail_dir = [1.0, 0.0]
arm_length = {arm}
s_limits = [-8.0, 12.0]
theta_limits_deg = {limits}
[robots.{name}.bindings]
x = "xpos({name})"
y = "ypos({name})"
[[robots.{name}.motors]]
port = "A"
joint = "s"
deg_per_unit = 80.0
[[robots.{name}.motors]]
port = "C"
joint = "theta"
deg_per_unit = 5.0
"""


def tiny_scene(obstacles: list[tuple[float, float, float, float]]) -> str:
    """Scene text; each obstacle is an axis-aligned rectangle ``(x0, y0, x1, y1)``."""
    parts = ['format = "cplus.scene/1"', 'name = "tiny"',
             "[grid]", "x_min = 0", "x_max = 3", "y_min = 0", "y_max = 4"]
    for k, (x0, y0, x1, y1) in enumerate(obstacles):
        ring = [[x0, y0], [x1, y0], [x1, y1], [x0, y1], [x0, y0]]
        parts += ["[[obstacles]]", f'name = "o{k}"', f"points = {ring}"]
    parts.append(_ROBOT.format(name="r1", rail_y=-3.0, arm=4.5, limits="[5.0, 175.0]"))
    parts.append(_ROBOT.format(name="r2", rail_y=7.0, arm=5.5, limits="[-175.0, -5.0]"))
    parts += ["[payload]", "length = 2.0", "tolerance_sq = 0.6", 'holds = "on"',
              "[payload.ends.pl1]", 'x = "xpay(pl1)"', 'y = "ypay(pl1)"',
              "[payload.ends.pl2]", 'x = "xpay(pl2)"', 'y = "ypay(pl2)"']
    return "\n".join(parts) + "\n"
