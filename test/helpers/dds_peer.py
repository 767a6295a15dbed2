"""A coordinator-like peer for the multi-host test, run as a script in another network namespace.

``python dds_peer.py r00c00,r00c01`` subscribes to each panel's ``closure``, ``status`` and
``joint_states`` and prints one JSON line per sample on stdout::

    {"event": "sample", "topic": "closure", "panel": "r00c00", "value": 0.12, "t": 12.3}

(``t`` is this process's monotonic clock, which is the host's: the test compares it with its
own). It prints ``{"event": "ready"}`` once its publishers and subscriptions exist. A line
``send 0.8`` on stdin makes it publish that closure setpoint to every panel at 5 Hz from then
on, in one ``/facade/setpoints`` message as the coordinator does (``stop`` stops sending);
names and QoS come from the contract, as everywhere else.
"""

import json
import sys
import threading
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from flectofold_ros.runtime.interfaces import message_class, publisher, subscription
from flectofold_ros.wire import contract

SEND_PERIOD_S = 0.2


def main():
    panels = sys.argv[1].split(',')
    rclpy.init()
    node = Node('multi_host_peer')
    lock = threading.Lock()
    setpoint = [None]

    def emit(**fields):
        with lock:
            print(json.dumps(fields), flush=True)

    def sample(topic, panel, value):
        emit(event='sample', topic=topic, panel=panel, value=value, t=time.monotonic())

    joint_state = message_class(contract.FACADE_SETPOINTS.msgtype)
    setpoints = publisher(node, contract.FACADE_SETPOINTS)
    for panel in panels:
        subscription(node, contract.CLOSURE.of(panel),
                     lambda m, p=panel: sample('closure', p, m.data))
        subscription(node, contract.STATUS.of(panel),
                     lambda m, p=panel: sample('status', p, m.data))
        subscription(node, contract.JOINT_STATES.of(panel),
                     lambda m, p=panel: sample('joint_states', p,
                                               [list(m.name), list(m.position)]))

    def send():
        if setpoint[0] is not None:
            setpoints.publish(joint_state(name=panels, position=[setpoint[0]] * len(panels)))

    def read_commands():
        for line in sys.stdin:
            words = line.split()
            if words[:1] == ['send']:
                setpoint[0] = float(words[1])
                emit(event='sending', value=setpoint[0], t=time.monotonic())
            elif words[:1] == ['stop']:
                setpoint[0] = None

    node.create_timer(SEND_PERIOD_S, send)
    threading.Thread(target=read_commands, daemon=True).start()
    emit(event='ready')
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:
        # Ctrl-C shuts the context down under a callback being handed its message: pybind
        # then fails to convert it ("Unable to convert call argument"; once in a full run)
        if rclpy.ok():
            raise
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()
