"""The contract's topics as rclpy objects: message classes, QoS, publishers, subscriptions.

Nodes create every publisher and subscription of a :class:`~flectofold_ros.wire.contract.Topic`
through :func:`publisher` and :func:`subscription`, so the name, the type and the QoS come
from :mod:`flectofold_ros.wire.contract` and nowhere else.
"""

import importlib

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy


def message_class(msgtype):
    """Import and return the rclpy message class of ``package/msg/Name``; ValueError if none."""
    package, kind, name = (msgtype.split('/') + ['', '', ''])[:3]
    if kind not in ('msg', 'srv') or not package or not name:
        raise ValueError(f'{msgtype!r} is not an interface type name like std_msgs/msg/String')
    try:
        return getattr(importlib.import_module(f'{package}.{kind}'), name)
    except (ImportError, AttributeError):
        raise ValueError(f'interface type {msgtype} is not installed') from None


def qos_profile(qos):
    """Return the rclpy ``QoSProfile`` of a :class:`~flectofold_ros.wire.contract.Qos`."""
    return QoSProfile(
        depth=qos.depth,
        reliability=ReliabilityPolicy.RELIABLE if qos.reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if qos.latched else DurabilityPolicy.VOLATILE)


def publisher(node, topic):
    """Create ``node``'s publisher of a contract :class:`~flectofold_ros.wire.contract.Topic`."""
    return node.create_publisher(message_class(topic.msgtype), topic.name, qos_profile(topic.qos))


def subscription(node, topic, callback, qos=None, **kwargs):
    """Subscribe ``node`` to a contract topic, with its QoS or the contract ``qos`` given."""
    return node.create_subscription(message_class(topic.msgtype), topic.name, callback,
                                    qos_profile(qos or topic.qos), **kwargs)


def client(node, service_name, type_name):
    """Create ``node``'s client of a contract service."""
    return node.create_client(message_class(type_name), service_name)


def service(node, panel_service_name, callback, type_name):
    """Serve a contract service on ``node``: absolute name, type ``package/srv/Name``."""
    return node.create_service(message_class(type_name), panel_service_name, callback)


def offered(publishers):
    """Return ``(latched, reliable)`` of a topic's publishers, as a recorder mirrors them.

    ``publishers`` is what ``get_publishers_info_by_topic`` gives; each is true when every
    publisher offers transient local and reliable delivery.
    """
    latched = all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
                  for p in publishers)
    reliable = all(p.qos_profile.reliability == ReliabilityPolicy.RELIABLE for p in publishers)
    return latched, reliable
