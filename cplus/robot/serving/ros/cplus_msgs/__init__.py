"""ROS message types of ``cplus serve --ros``: ``cplus_msgs/Serve`` (an action), built at import
time from ``action/Serve.action`` with genpy, so that no catkin build is needed.

Put the directory that holds this package on ``PYTHONPATH`` for ROS's command-line tools to
know the type (``rostopic echo /cplus_serve/feedback``); the server adds it itself.
"""
