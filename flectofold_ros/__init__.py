"""The ROS 2 shell of :mod:`flectofold_model`: thin nodes over one contract, no model logic.

- :mod:`.contract`: every topic, type, QoS and the words on them (pure);
- :mod:`.interfaces`: the contract as rclpy objects; :mod:`.parameters`: parameter specs;
  :mod:`.diagnostics`: REP-107 statuses; :mod:`.runner`: how every executable runs;
- ``nodes/``: one node per file; ``bringup/``: the whole facade through a day;
- ``recording/``, ``rerun/``, ``commands/``: the parts that need no rclpy.
"""
