"""What goes on the wire: the one contract of topics and QoS and the layouts of the messages.

No rclpy, by rule (``test/test_package.py`` holds every module of this folder to it): the
contract (:mod:`.contract`), the layouts of the array messages (:mod:`.panel_states`,
:mod:`.facade_setpoints`, :mod:`.markers` and its :mod:`.colours`), the fault requests
(:mod:`.fault_injection`) and the announcements of one facade per domain (:mod:`.presence`).
The ROS shell (``flectofold_ros.nodes``, ``flectofold_ros.runtime``) fills and reads them.
"""
