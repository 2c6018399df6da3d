"""The seven messages of the action ``cplus_msgs/Serve``, generated at import time.

An ``.action`` file has three parts (goal, result, feedback); actionlib wraps each in a message
with a header and a goal id or status, and the action in a message of the three, as ROS's
message generators do (``genaction``). The texts are put together here and handed to
``genpy.dynamic.generate_dynamic``, with the texts of the messages they depend on.
"""
from __future__ import annotations

import os

import actionlib_msgs.msg
import std_msgs.msg
from genpy.dynamic import generate_dynamic

__all__ = ["ServeAction", "ServeActionFeedback", "ServeActionGoal", "ServeActionResult", "ServeFeedback",
           "ServeGoal", "ServeResult", "ACTION_TEXT"]

_PKG = "cplus_msgs"
_HERE = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(_HERE, os.pardir, "action", "Serve.action"), encoding="utf-8") as _f:
    ACTION_TEXT = _f.read()


def _parts(text: str) -> list[str]:
    parts = [p.strip("\n") + "\n" for p in text.split("\n---\n")]
    if len(parts) != 3:
        raise ValueError("an .action file has three parts separated by ---")
    return parts


def _texts(name: str, action: str) -> dict[str, str]:
    goal, result, feedback = _parts(action)
    return {
        f"{name}Goal": goal,
        f"{name}Result": result,
        f"{name}Feedback": feedback,
        f"{name}ActionGoal": f"Header header\nactionlib_msgs/GoalID goal_id\n{name}Goal goal\n",
        f"{name}ActionResult": f"Header header\nactionlib_msgs/GoalStatus status\n{name}Result result\n",
        f"{name}ActionFeedback": f"Header header\nactionlib_msgs/GoalStatus status\n{name}Feedback feedback\n",
        f"{name}Action": f"{name}ActionGoal action_goal\n{name}ActionResult action_result\n"
                         f"{name}ActionFeedback action_feedback\n",
    }


def _build(name: str, action: str) -> dict[str, type]:
    own = _texts(name, action)
    core = f"{name}Action"
    deps = {f"{_PKG}/{n}": t for n, t in own.items() if n != core}
    deps["std_msgs/Header"] = std_msgs.msg.Header._full_text
    deps["actionlib_msgs/GoalID"] = actionlib_msgs.msg.GoalID._full_text
    deps["actionlib_msgs/GoalStatus"] = actionlib_msgs.msg.GoalStatus._full_text.split("\n" + "=" * 80 + "\n")[0]
    cat = own[core] + "".join(f"\n{'=' * 80}\nMSG: {t}\n{text}" for t, text in deps.items())
    classes = generate_dynamic(f"{_PKG}/{core}", cat)
    return {n: classes[f"{_PKG}/{n}"] for n in own}


_classes = _build("Serve", ACTION_TEXT)
ServeAction = _classes["ServeAction"]
ServeActionGoal = _classes["ServeActionGoal"]
ServeActionResult = _classes["ServeActionResult"]
ServeActionFeedback = _classes["ServeActionFeedback"]
ServeGoal = _classes["ServeGoal"]
ServeResult = _classes["ServeResult"]
ServeFeedback = _classes["ServeFeedback"]
