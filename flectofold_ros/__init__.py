"""The ROS 2 shell of :mod:`flectofold_model`: thin nodes over one contract, no model logic.

- ``wire/``: what goes on the wire, no rclpy (:mod:`.wire.contract`: every topic, type, QoS
  and the words on them; the array messages' layouts; fault requests; presence);
- ``runtime/``: how the processes run (executables, runner, interfaces, parameters,
  diagnostics, domain watch);
- ``nodes/``: one node per file; ``bringup/``: the whole facade through a day;
- ``recording/``, ``rerun/``, ``commands/``, ``hardware/``, ``bms/``, ``sitenet/``: the parts
  that need no rclpy.
"""
