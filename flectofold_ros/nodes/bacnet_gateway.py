"""The facade on BACnet/IP: a building management system reads it and commands overrides.

The node serves the facade's object table (:mod:`flectofold_ros.bms.objects`) as a BACnet
device with bacpypes3 and connects it to the graph: panel states, the coordinator's command
and its storm latch in; a BMS's closure commands out as the coordinator's overrides
(priorities, bounds and the storm: :mod:`flectofold_ros.bms.priority`). bacpypes3 runs in an
asyncio loop on a thread of its own; rclpy spins on the main thread as in every node of the
package (:mod:`flectofold_ros.runtime.runner`). ROS callbacks hand their data to the loop with
``call_soon_threadsafe``; the gateway's commands are published from the loop's thread (an
rclpy publisher may be used from any thread). Objects, priority mapping, parameters and PICS:
``msg_docs/bacnet_gateway.md``.
"""

import asyncio
import concurrent.futures
import logging
import math
import sys
import threading

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros.bms.gateway import (check_bindable, check_device_name, FacadeGateway, LOGGER,
                                        MAX_NAME_CHARS, parse_address)
from flectofold_ros.runtime import diagnostics
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.runtime.parameters import boolean, declare_all, double, integer, string
from flectofold_ros.runtime.runner import configure_or_destroy, Program, run_nodes
from flectofold_ros.wire import contract, panel_states

NODE_NAME = 'bacnet_gateway'
USAGE = 'bacnet_gateway [--ros-args -p name:=value ...]'
#: The coordinator's status on /diagnostics and its storm key (``coordinator_node.md``).
COORDINATOR_STATUS = f'{contract.FACADE_NODE_NAMESPACE}/{contract.COORDINATOR_NODE}: schedule'
STORM_KEY = 'storm_latched'
#: BACnet device instances: 0 .. 2^22 - 2 (4194303 is the wildcard).
MAX_DEVICE_INSTANCE = 4194302
#: Wall seconds within which the BACnet application must be up at start.
START_TIMEOUT_S = 30.0

#: name -> Spec.
PARAMETERS = {
    'facade_file': string('', 'Facade description YAML; empty: the embedded demonstrator'),
    'address': string('127.0.0.1/32:47808', 'BACnet/IP address to serve on: IPv4 address, '
                      'prefix length and UDP port', constraints='a.b.c.d/prefix:port; '
                      '127.0.0.1 unless allow_any_address'),
    'allow_any_address': boolean(False, 'Serve on an address other than 127.0.0.1 (a site '
                                 'network: see the threat model)'),
    'device_instance': integer(1001, 'BACnet device instance, unique on the BACnet '
                               'internetwork', 0, MAX_DEVICE_INSTANCE),
    'device_name': string('flectofold facade', 'BACnet device object name',
                          constraints=f'1 to {MAX_NAME_CHARS} printable characters'),
    'closure_cov_increment_percent': double(
        1.0, 'COV increment of the closure inputs and commands [%]', 0.1, 50.0),
    'pressure_cov_increment_pa': double(100.0, 'COV increment of the pressure inputs [Pa]',
                                        1.0, 10000.0),
    'override_refresh_s': double(
        600.0, "Every override in force is sent again this often, within the coordinator's "
        'override life (2 h by default) [s, wall clock]', 1.0, 3600.0),
    'state_timeout_s': double(10.0, "A panel's inputs are flagged unreliable when its state is "
                              'older than this [s, wall clock]', 0.5, 3600.0),
    'diagnostics_period_s': double(1.0, 'Period of /diagnostics, wall clock [s]', 0.1, 60.0),
}


class _ToRosLog(logging.Handler):
    """Python logging (the gateway's, bacpypes3's) into the node's ROS log."""

    def __init__(self, node):
        super().__init__(logging.INFO)
        self._node = node

    def emit(self, record):
        logger = self._node.get_logger()
        text = self.format(record)
        if record.levelno >= logging.ERROR:
            logger.error(text)
        elif record.levelno >= logging.WARNING:
            logger.warning(text)
        else:
            logger.info(text)


class BacnetGatewayNode(Node):
    """Node ``bacnet_gateway`` in namespace ``/facade``: the BACnet device of the facade."""

    def __init__(self, **kwargs):
        kwargs.setdefault('namespace', contract.FACADE_NODE_NAMESPACE)
        super().__init__(NODE_NAME, **kwargs)
        self.gateway = None
        self._loop = None
        self._thread = None
        configure_or_destroy(self, self._configure)

    def _value(self, name):
        return self.get_parameter(name).value

    def _configure(self):
        declare_all(self, PARAMETERS)
        try:
            name = check_device_name(self._value('device_name'))
        except ValueError as error:
            raise ValueError(f'parameter {error}') from None
        address = parse_address(self._value('address'), self._value('allow_any_address'))
        check_bindable(address)
        self.facade = load_facade(self._value('facade_file') or DEFAULT_FACADE)
        self.panel_ids = list(self.facade.panel_ids)
        self._index = panel_states.index_lookup(self.panel_ids)
        self._state_s = dict.fromkeys(self.panel_ids)
        self._stale = set()
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._override = publisher(self, contract.OVERRIDE)
        self._override_clear = publisher(self, contract.OVERRIDE_CLEAR)
        self._diagnostics = publisher(self, contract.DIAGNOSTICS)
        self.overrides_sent = 0
        self.clears_sent = 0
        self.storm_latched = None
        self.rejected_states = 0
        self._log_handler = _ToRosLog(self)
        LOGGER.addHandler(self._log_handler)
        LOGGER.setLevel(logging.INFO)
        self._start_bacnet(address, name)
        subscription(self, contract.PANEL_STATES, self._on_panel_states, contract.OBSERVER)
        subscription(self, contract.FACADE_SETPOINTS, self._on_setpoints)
        subscription(self, contract.DIAGNOSTICS, self._on_diagnostics)
        self.create_timer(self._value('override_refresh_s'), self._refresh, clock=self._steady)
        self.create_timer(min(1.0, self._value('state_timeout_s') / 2), self._check_stale,
                          clock=self._steady)
        self.create_timer(self._value('diagnostics_period_s'), self._report, clock=self._steady)
        self.get_logger().info(
            f'{self.facade.name}: {len(self.panel_ids)} panels as BACnet device '
            f'{self._value("device_instance")} {name!r} on {address.addrTuple[0]}:'
            f'{address.addrTuple[1]} ({2 + 4 * len(self.panel_ids)} objects)')

    # -- the asyncio side -------------------------------------------------------------------

    def _start_bacnet(self, address, name):
        started = concurrent.futures.Future()
        loop = asyncio.new_event_loop()

        async def create():
            return FacadeGateway.create(
                self.panel_ids, address, self._value('device_instance'), name,
                self._value('closure_cov_increment_percent'),
                self._value('pressure_cov_increment_pa'),
                on_override=self._send_overrides, on_clear=self._send_clears)

        def serve():
            asyncio.set_event_loop(loop)
            try:
                started.set_result(loop.run_until_complete(create()))
            except BaseException as error:  # noqa: B902 handed to the starting thread
                started.set_exception(error)
                loop.close()
                return
            loop.run_forever()
            loop.run_until_complete(loop.shutdown_asyncgens())
            loop.close()

        self._loop = loop
        self._thread = threading.Thread(target=serve, name='bacnet', daemon=True)
        self._thread.start()
        self.gateway = started.result(timeout=START_TIMEOUT_S)

    def _in_loop(self, function, *args):
        """Run ``function(*args)`` on the BACnet loop's thread (from a ROS callback)."""
        if self._loop is not None and not self._loop.is_closed():
            self._loop.call_soon_threadsafe(function, *args)

    def stop_bacnet(self, timeout_s=10.0):
        """Close the BACnet application and stop its loop and thread (idempotent)."""
        if self._loop is not None and not self._loop.is_closed() and self._thread.is_alive():
            def close():
                self.gateway.close()
                self._loop.stop()
            self._loop.call_soon_threadsafe(close)
            self._thread.join(timeout_s)
        LOGGER.removeHandler(self._log_handler)

    def _send_overrides(self, overrides):
        """Publish ``{panel id: closure}`` on the override topic (the loop's thread)."""
        message = JointState()
        message.header.stamp = self.get_clock().now().to_msg()
        message.name = list(overrides)
        message.position = [float(closure) for closure in overrides.values()]
        self._override.publish(message)
        self.overrides_sent += 1

    def _send_clears(self, panel_ids):
        self._override_clear.publish(String(data=','.join(panel_ids)))
        self.clears_sent += 1

    # -- the ROS side -----------------------------------------------------------------------

    def _on_panel_states(self, message):
        try:
            table = panel_states.unpack(message)
        except ValueError as error:
            self.rejected_states += 1
            self.get_logger().warning(f'rejected panel_states: {error}',
                                      throttle_duration_sec=1.0)
            return
        index = panel_states.indices(table, self._index)
        now_s = self._steady.now().nanoseconds * 1e-9
        faults = panel_states.fault_words(table)
        rows = []
        for row, panel in enumerate(index.tolist()):
            if panel < 0:
                continue
            panel_id = self.panel_ids[panel]
            self._state_s[panel_id] = now_s
            self._stale.discard(panel_id)
            rows.append((panel_id, float(table['closure'][row]),
                         float(table['pressure_pa'][row]), faults[row]))
        self._in_loop(self._apply_states, rows)

    def _apply_states(self, rows):
        for row in rows:
            self.gateway.set_panel_state(*row)

    def _on_setpoints(self, message):
        rows = [(name, closure) for name, closure in zip(message.name, message.position)
                if math.isfinite(closure) and 0.0 <= closure <= 1.0]
        self._in_loop(self._apply_setpoints, rows)

    def _apply_setpoints(self, rows):
        for panel_id, closure in rows:
            self.gateway.set_automatic(panel_id, closure)

    def _on_diagnostics(self, message):
        for status in message.status:
            if status.name != COORDINATOR_STATUS:
                continue
            values = {kv.key: kv.value for kv in status.values}
            if STORM_KEY in values:
                latched = values[STORM_KEY] == 'True'
                if latched != self.storm_latched:
                    self.get_logger().info(f'storm latch {"set" if latched else "released"}')
                self.storm_latched = latched
                self._in_loop(self.gateway.set_storm, latched)

    def _refresh(self):
        self._in_loop(self.gateway.refresh)

    def _check_stale(self):
        now_s = self._steady.now().nanoseconds * 1e-9
        timeout_s = self._value('state_timeout_s')
        for panel_id, seen_s in self._state_s.items():
            if seen_s is not None and panel_id not in self._stale and now_s - seen_s > timeout_s:
                self._stale.add(panel_id)
                self._in_loop(self.gateway.mark_stale, panel_id)

    # -- diagnostics ------------------------------------------------------------------------

    def diagnostic_status(self):
        """Return the gateway's REP-107 status: writes, refusals by error code, storm."""
        gateway = self.gateway
        refused = dict(gateway.refused)
        values = {'writes_accepted': gateway.writes_accepted,
                  'requests_refused': sum(refused.values()),
                  **{f'refused_{code}': count for code, count in sorted(refused.items())},
                  'last_refusal': gateway.last_refusal,
                  'overrides_sent': self.overrides_sent, 'clears_sent': self.clears_sent,
                  'overrides_in_force': sum(c is not None for c in gateway.overrides.values()),
                  'slots_ended_by_storm': gateway.slots_ended_by_storm,
                  'storm_latched': 'unknown' if self.storm_latched is None
                  else self.storm_latched,
                  'stale_panels': len(self._stale), 'rejected_panel_states': self.rejected_states}
        level, text = diagnostics.OK, 'serving'
        if self.storm_latched is None:
            level, text = diagnostics.WARN, 'no storm latch heard from the coordinator yet'
        elif self._stale:
            level, text = diagnostics.WARN, f'{len(self._stale)} panel(s) without a fresh state'
        return diagnostics.status(self, level, 'bacnet', self.facade.name, text, values)

    def _report(self):
        self._diagnostics.publish(diagnostics.diagnostic_array(self, [self.diagnostic_status()]))


class GatewayProgram(Program):
    """The gateway node; closing stops the BACnet application first."""

    def close(self, interrupted):
        for node in self.nodes:
            node.stop_bacnet()
        return None


def main(args=None):
    """``ros2 run flectofold_ros bacnet_gateway --ros-args -p address:=127.0.0.1/32:47808``."""
    return run_nodes(NODE_NAME, args, lambda: GatewayProgram([BacnetGatewayNode()]), USAGE,
                     PARAMETERS)


if __name__ == '__main__':
    sys.exit(main())
