"""ROS actionlib for ``cplus serve --ros``: an action server of goal requests (optional extra).

Nothing else in the project imports this module or ROS. It needs ROS 1 (Debian's
``ros-core python3-rospy python3-actionlib python3-genpy python3-genmsg
python3-actionlib-msgs``) and a running ``roscore`` named by ``ROS_MASTER_URI``. Debian
installs rospy for its own Python 3 in ``/usr/lib/python3/dist-packages``; when rospy cannot
be imported otherwise, that directory is *appended* to ``sys.path`` here, and only here (so
the project's own packages keep their versions, and a plain install never sees ROS).

The action type is the project's ``cplus_msgs/Serve`` (``ros/cplus_msgs/action/Serve.action``
beside this module), generated at run time with genpy, so no catkin build is needed:

* goal: ``string request``, in the domain's terms (``deliver(office3,office2)``);
* feedback, once per cycle while the goal is in progress: the server's goal ``id``, the
  ``cycle``, the actions ``executed`` and the ``plan`` that remains (one step per string);
* result: ``id``, ``status`` (succeeded, preempted, recalled, aborted, rejected), ``reason``,
  the ``cycle`` it took effect and the ``done_cycle``.

An ``actionlib.ActionServer`` (several goals at once, as the server serves several requests)
under the namespace ``--ros-name`` (default ``/cplus_serve``): any actionlib client works
(``actionlib.SimpleActionClient(ns, ServeAction)``), and so do ROS's command-line tools once
the message package is on ``PYTHONPATH`` (:data:`MSG_PATH`)::

    export PYTHONPATH=$(python -c 'import cplus.robot.serving.ros_bridge as r; print(r.MSG_PATH)')
    rostopic pub -1 /cplus_serve/goal cplus_msgs/ServeActionGoal '{goal: {request: "deliver(office3,office2)"}}'
    rostopic echo /cplus_serve/feedback
    rostopic pub -1 /cplus_serve/cancel actionlib_msgs/GoalID '{id: ""}'    # every goal

**The master restarting.** ROS 1 nodes register with the master once; a master that is
restarted (roscore killed and started again, a respawned roscore) knows none of them, so new
clients find no action server, while the connections already made go on. The channel
therefore watches its registration (:class:`MasterWatch`: the master's ``lookupNode`` for this
node, every :data:`MASTER_CHECK_S`), and when the master does not know the node it registers
every publisher, subscriber and service of the node again, as rospy does at start-up (the
master's ``registerPublisher``/``registerSubscriber``/``registerService``, and the node's own
``publisherUpdate`` with the publishers the master names), and says so in one line. The goals
in flight go on over their connections; nothing of the server's state lives in the master
(it keeps no parameters), so registering again is safe; exiting for roslaunch's ``respawn``
would abort every goal in flight and stop the robot for nothing.

The states of a goal here are actionlib's: a request the domain cannot express is REJECTED
with the reason as the status text; a pending goal becomes ACTIVE when the loop takes it; a
cancellation is PREEMPTING until the cancellation's events have done their work (a package on
board goes back to its origin), then PREEMPTED (RECALLED when it was still pending).
"""
from __future__ import annotations

import os
import sys
import threading
import time
import xmlrpc.client
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from cplus.robot.serving.goals import Feedback, Goal, GoalBoard, GoalStatus, GoalWatcher

__all__ = ["DEBIAN_DIST", "INSTALL_HINT", "MASTER_CHECK_S", "MSG_PATH", "ActionChannel", "MasterWatch", "RosSetup",
           "RosUnavailable", "import_ros"]

DEBIAN_DIST = "/usr/lib/python3/dist-packages"
MSG_PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ros")
"""The directory that holds the ``cplus_msgs`` package (for ``PYTHONPATH``)."""
MASTER_CHECK_S = 0.5
"""How often the channel asks the master whether it still knows this node (a restarted master
is seen, and the node registered again, within about a second)."""
INSTALL_HINT = ("apt-get install ros-core python3-rospy python3-actionlib python3-genpy python3-genmsg "
                "python3-actionlib-msgs")


class RosUnavailable(RuntimeError):
    """ROS cannot be used: not installed, or no master to talk to. The message says what to do."""


def import_ros() -> dict[str, Any]:
    """Import rospy, actionlib, rosgraph and the action's messages, reaching Debian's
    ``dist-packages`` if need be. Raises :class:`RosUnavailable`."""
    missing = ""
    try:
        return _modules()
    except ImportError as exc:
        missing = exc.name or str(exc)
    if os.path.isdir(DEBIAN_DIST) and DEBIAN_DIST not in sys.path:
        sys.path.append(DEBIAN_DIST)
        try:
            return _modules()
        except ImportError as exc:
            missing = exc.name or str(exc)
    raise RosUnavailable(f"--ros needs ROS 1 for Python {sys.version_info.major}.{sys.version_info.minor} "
                         f"(cannot import {missing}): {INSTALL_HINT}")


def _modules() -> dict[str, Any]:
    import actionlib
    import actionlib_msgs.msg
    import rosgraph
    import rospy
    if MSG_PATH not in sys.path:
        sys.path.append(MSG_PATH)
    import cplus_msgs.msg
    return {"rospy": rospy, "actionlib": actionlib, "rosgraph": rosgraph, "GoalStatus": actionlib_msgs.msg.GoalStatus,
            "msgs": cplus_msgs.msg}


@dataclass
class RosSetup:
    """ROS, imported and with a master that answers."""

    modules: dict[str, Any]
    master_uri: str

    @classmethod
    def check(cls) -> RosSetup:
        """Import ROS and find the master at ``ROS_MASTER_URI``. Raises :class:`RosUnavailable`."""
        modules = import_ros()
        uri = os.environ.get("ROS_MASTER_URI")
        if not uri:
            raise RosUnavailable("--ros: ROS_MASTER_URI is not set; start roscore (roscore -p 11311) and set "
                                 "ROS_MASTER_URI=http://127.0.0.1:11311 (and ROS_HOSTNAME=127.0.0.1)")
        try:
            online = modules["rosgraph"].Master("/cplus_serve").is_online()
        except Exception:  # noqa: BLE001 - a malformed URI, a refused connection: the same answer
            online = False
        if not online:
            raise RosUnavailable(f"--ros: no ROS master answers at {uri}: start roscore (roscore -p PORT) or fix "
                                 "ROS_MASTER_URI")
        return cls(modules, uri)


class MasterWatch:
    """Keeps this node registered with the ROS master, through restarts of the master.

    A thread asks the master every :data:`MASTER_CHECK_S` whether it knows the node
    (``lookupNode``); when it does not (a restarted master), every topic and service of the
    node is registered again (:meth:`register`). ``say`` hears one line when the master stops
    answering and when the node is registered again. :meth:`stop` ends the thread."""

    def __init__(self, rospy, master_uri: str, say: Callable[[str], None] = lambda text: None) -> None:
        self.rospy = rospy
        self.say = say
        self.master_uri = master_uri
        self.registrations = 0           # how many times the node was registered again
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="cplus-serve-ros-master", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self, timeout: float = 0.05) -> None:
        """End the watch: at once when it waits for its next check; a check under way (an
        XML-RPC call to a slow master) is not waited for (the thread is a daemon, and the
        server's stop must stay within its grace period)."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout)

    def _watch(self) -> None:
        rospy = self.rospy
        caller = rospy.get_caller_id()
        node_uri = rospy.get_node_uri()
        silent = False
        while not self._stop.wait(MASTER_CHECK_S):
            master = xmlrpc.client.ServerProxy(self.master_uri)
            try:
                answer: Any = master.lookupNode(caller, caller)
                code, _, uri = answer
            except (OSError, xmlrpc.client.Error):
                if not silent:
                    self.say(f"the ROS master at {self.master_uri} does not answer; goals in flight go on, new ROS "
                             "clients wait for it")
                    silent = True
                continue
            if code == 1 and uri == node_uri:
                silent = False
                continue
            try:
                self.register(master, caller, node_uri)
            except (OSError, xmlrpc.client.Error):
                continue                   # tried again at the next check
            silent = False
            self.registrations += 1
            self.say(f"the ROS master at {self.master_uri} did not know this node (restarted): registered its "
                     "action server again")

    def register(self, master, caller: str, node_uri: str) -> None:
        """Register every publisher, subscriber and service of this node with ``master``, and
        tell the node the publishers of the topics it subscribes to (as rospy's RegManager
        does when the node starts)."""
        from rospy.impl.registration import get_service_manager, get_topic_manager
        tm, sm = get_topic_manager(), get_service_manager()
        node = xmlrpc.client.ServerProxy(node_uri)
        for topic, data_type in tm.get_publications():
            master.registerPublisher(caller, topic, data_type, node_uri)
        for topic, data_type in tm.get_subscriptions():
            code, _, publishers = master.registerSubscriber(caller, topic, data_type, node_uri)
            if code == 1 and publishers:
                node.publisherUpdate("/master", topic, publishers)
        for service, service_uri in sm.get_services():
            master.registerService(caller, service, service_uri, node_uri)


class _RosGoal(GoalWatcher):
    """One actionlib goal handle, told what happens to the server's goal (from the board's
    dispatcher, with no lock of the server's held: the handle's methods take actionlib's
    ``action_server.lock``, which actionlib holds while its callbacks call the board)."""

    def __init__(self, channel: ActionChannel, handle, ros_id: str) -> None:
        self.channel = channel
        self.handle = handle
        self.ros_id = ros_id

    def _result(self, goal: Goal, status: GoalStatus):
        msgs = self.channel.msgs
        return msgs.ServeResult(id=goal.id, status=status.value, reason=goal.reason, cycle=goal.cycle or 0,
                                done_cycle=goal.done_cycle or 0)

    def status(self, goal: Goal, status: GoalStatus) -> None:
        h = self.handle
        S = self.channel.GoalStatus
        now = h.get_goal_status().status
        text = goal.reason
        if status is GoalStatus.ACTIVE:
            h.set_accepted(f"goal {goal.id}, slot {goal.slot}")
        elif status is GoalStatus.PREEMPTING:
            if now in (S.PENDING, S.ACTIVE):
                h.set_cancel_requested()
        elif status is GoalStatus.SUCCEEDED:
            h.set_succeeded(self._result(goal, status), f"goal {goal.id} done at cycle {goal.done_cycle}")
        elif status in (GoalStatus.PREEMPTED, GoalStatus.RECALLED):
            h.set_canceled(self._result(goal, status), text or "cancelled")
        elif status is GoalStatus.REJECTED:
            h.set_rejected(self._result(goal, status), text)
        elif status is GoalStatus.ABORTED:
            if now in (S.PENDING, S.RECALLING):     # actionlib aborts active goals only
                h.set_rejected(self._result(goal, status), text)
            else:
                h.set_aborted(self._result(goal, status), text)
        if goal.final:
            self.channel._forget(self.ros_id)

    def feedback(self, goal: Goal, feedback: Feedback) -> None:
        msgs = self.channel.msgs
        self.handle.publish_feedback(msgs.ServeFeedback(
            id=goal.id, cycle=feedback.cycle, executed=list(feedback.executed),
            plan=[", ".join(step) for step in feedback.plan]))


class ActionChannel:
    """An actionlib action server that feeds a :class:`GoalBoard`.

    Args:
        board: the server's goals.
        name: the action namespace (``cplus_serve``: topics ``/cplus_serve/goal``, ...).
        setup: ROS, checked (:meth:`RosSetup.check`).
        node: the ROS node name (anonymous, so that two servers may run).
    """

    action_type = "cplus_msgs/Serve"

    def __init__(self, board: GoalBoard, name: str, setup: RosSetup, node: str = "cplus_serve",
                 say: Callable[[str], None] = lambda text: None) -> None:
        self.board = board
        self.namespace = "/" + name.strip("/")
        self.setup = setup
        self.node = node
        m = setup.modules
        self.rospy = m["rospy"]
        self.actionlib = m["actionlib"]
        self.GoalStatus = m["GoalStatus"]
        self.msgs = m["msgs"]
        self._ids: dict[str, int] = {}
        self._lock = threading.Lock()
        self._server = None
        self._open = False
        self.say = say
        self.watch: MasterWatch | None = None

    def start(self) -> None:
        """Register the node with the master and start the action server."""
        rospy = self.rospy
        if not rospy.core.is_initialized():
            rospy.init_node(self.node, anonymous=True, disable_signals=True)
        server = self.actionlib.ActionServer(self.namespace, self.msgs.ServeAction, self._on_goal, self._on_cancel,
                                             auto_start=False)
        server.start()
        self._server = server
        self.board.open_channel()
        self._open = True
        self.watch = MasterWatch(rospy, self.setup.master_uri, self.say)
        self.watch.start()

    def _on_goal(self, handle) -> None:
        """actionlib's goal callback (its lock held): the board is called, and nothing waits."""
        ros_id = handle.get_goal_id().id
        request = handle.get_goal().request
        # whose share of open goals: the node that sent it (actionlib's ids are NODE-COUNT-STAMP)
        parts = ros_id.rsplit("-", 2)
        client = ("ros", parts[0] if len(parts) == 3 else ros_id)
        goal = self.board.submit(request, _RosGoal(self, handle, ros_id), f"ros {ros_id}", client=client)
        with self._lock:
            if not goal.final:
                self._ids[ros_id] = goal.id

    def _on_cancel(self, handle) -> None:
        """actionlib's cancel callback (its lock held)."""
        with self._lock:
            gid = self._ids.get(handle.get_goal_id().id)
        if gid is not None:
            try:
                self.board.cancel(gid, "ros")
            except KeyError:                  # ended and forgotten meanwhile
                pass

    def _forget(self, ros_id: str) -> None:
        with self._lock:
            self._ids.pop(ros_id, None)

    def close(self, timeout: float = 1.5) -> None:
        """Stop taking goals (the run ended: open goals were aborted and told) and leave ROS,
        within ``timeout`` seconds."""
        if self.watch is not None:
            self.watch.stop()
        if self._open:
            self._open = False
            self.board.close_channel()
            time.sleep(0.3)                   # let rospy's publisher threads send the last results
            quit = threading.Thread(target=self.rospy.signal_shutdown, args=("cplus serve stopped",),
                                    name="cplus-serve-ros-shutdown", daemon=True)
            quit.start()
            quit.join(max(timeout - 0.3, 0.1))
