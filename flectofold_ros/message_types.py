"""Message classes from ROS type names such as ``sensor_msgs/msg/FluidPressure``."""

import importlib


def message_class(msgtype):
    """Import and return the rclpy message class of ``package/msg/Name``; ValueError if none."""
    package, kind, name = (msgtype.split('/') + ['', '', ''])[:3]
    if kind != 'msg' or not package or not name:
        raise ValueError(f'{msgtype!r} is not a message type name like std_msgs/msg/String')
    try:
        return getattr(importlib.import_module(f'{package}.msg'), name)
    except (ImportError, AttributeError):
        raise ValueError(f'message type {msgtype} is not installed') from None
