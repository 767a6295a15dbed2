"""The facade's BACnet/IP face for a building management system (``msg_docs/bacnet_gateway.md``).

:mod:`~flectofold_ros.bms.priority` is the priority mapping and the bounds of a write (pure
Python); :mod:`~flectofold_ros.bms.objects` the object table served with ``bacpypes3``;
:mod:`~flectofold_ros.bms.gateway` the application that answers a BMS and hands its commands
on. None of them imports rclpy: the node :mod:`flectofold_ros.nodes.bacnet_gateway` connects
them to the ROS graph.
"""
