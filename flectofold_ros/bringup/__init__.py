"""Bringing a whole facade up through a simulated day.

- :mod:`.plan`: the day's span, processes and every node's parameters, pure (no rclpy); the
  ``facade`` command and ``launch/facade.launch.py`` both build from it;
- :mod:`.monitor`: the node that learns the day's progress from the topics;
- :mod:`.cli`: the ``facade`` command.
"""
