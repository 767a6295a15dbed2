"""Multi-host over DDS: panels on one "host", a coordinator-like peer on another, a link between.

The hosts are network namespaces of this kernel, each with its own loopback and interfaces:
what crosses from one to the other crosses their veth link, or nothing does. Two networks:

- ``multicast``: one veth pair, one subnet (10.213.40.0/24), discovery by multicast
  (``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET``), as on one switched LAN;
- ``static_peers``: two subnets (10.213.40.0/24, 10.213.41.0/24) and a router namespace
  between them; a Linux router forwards unicast but no multicast, so discovery has to take
  ``ROS_STATIC_PEERS`` (with ``SUBNET``), as across a routed network.

Fast DDS is held to UDPv4 (``FASTDDS_BUILTIN_TRANSPORTS``) on both sides, so its shared-memory
transport cannot stand in for the network. ``msg_docs/multi_host.md`` says what this proves and
what it does not. Needs root and ``ip netns`` (CI has both); skipped otherwise.
"""

import json
import os
from pathlib import Path
import subprocess
import sys
import time

from netns import (Child, ip_command, shared_memory_mappings, skip_without_namespaces,
                   WAIT_RUNNING)
import pytest
from ros_graph import BIN, domain_for

from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph

ROOT = Path(__file__).resolve().parents[2]
PEER = ROOT / 'test' / 'helpers' / 'dds_peer.py'
PANELS = ('r00c00', 'r00c01')
PANEL_SIDE, PEER_SIDE = 0, 1
#: The setpoint the peer sends, and the closure the panels must pass on their way to it.
SETPOINT, PASSED = 0.8, 0.3
#: How long the link stays down, after a grace period for what was already on its way.
DOWN_GRACE_S, DOWN_S = 1.0, 3.0


class Link:
    """The panels' namespace (side 0) and the peer's (side 1), joined directly or routed.

    ``veths[side]`` is that side's own interface, ``addresses[side]`` its address.
    """

    def __init__(self, tag, discovery):
        self.discovery = discovery
        self.routed = discovery == 'static_peers'
        self.namespaces = (f'{tag}p', f'{tag}c')
        self.router = f'{tag}r' if self.routed else None
        self.veths = (f'{tag}vp', f'{tag}vc')  # at most 15 characters
        self.addresses = (('10.213.40.1', '10.213.41.2') if self.routed
                          else ('10.213.40.1', '10.213.40.2'))
        self.made = []

    def run(self, side, *command):
        """Run ``command`` inside side ``side``'s namespace."""
        return subprocess.run(['ip', 'netns', 'exec', self.namespaces[side], *command],
                              capture_output=True, text=True, timeout=20)

    def create(self):
        """Make the namespaces and links; skip where this machine cannot."""
        for namespace in [*self.namespaces, *([self.router] if self.routed else [])]:
            ip_command('netns', 'delete', namespace)  # a leftover of a killed run with this pid
            result = ip_command('netns', 'add', namespace)
            if result.returncode != 0:
                pytest.skip(f'ip netns add failed: {result.stderr.strip()}')
            self.made.append(namespace)
        if self.routed:
            pairs = [(0, f'{self.veths[0]}r', '10.213.40.254/24'),
                     (1, f'{self.veths[1]}r', '10.213.41.254/24')]
            for side, router_end, _ in pairs:
                self._veth(self.veths[side], self.namespaces[side], router_end, self.router)
            self._sh(self.router, 'echo 1 > /proc/sys/net/ipv4/ip_forward')
            for _, router_end, address in pairs:
                self._configure(self.router, router_end, address)
        else:
            self._veth(self.veths[0], self.namespaces[0], self.veths[1], self.namespaces[1])
        for side in (PANEL_SIDE, PEER_SIDE):
            self._configure(self.namespaces[side], self.veths[side], f'{self.addresses[side]}/24')
            self._route(side)
        for side in (PANEL_SIDE, PEER_SIDE):
            self.wait_running(side)

    def wait_running(self, side, timeout_s=10.0):
        """Wait until side ``side``'s veth is RUNNING, as a host's interface is before ROS starts.

        The kernel sets IFF_RUNNING about a second after a new veth comes up (its link watch
        is rate-limited), and Fast DDS lists only running interfaces when a participant
        starts: one started earlier sees loopback alone, announces 127.0.0.1 as its address
        and takes its host id from it, and its peer sends discovery to its own loopback.
        """
        result = self.run(side, sys.executable, '-c', WAIT_RUNNING, self.veths[side],
                          str(timeout_s))
        assert result.returncode == 0, result.stdout + result.stderr

    def delete(self):
        for namespace in self.made:  # a namespace takes its ends of the veths with it
            ip_command('netns', 'delete', namespace)

    @staticmethod
    def _veth(name, namespace, peer, peer_namespace):
        result = ip_command('link', 'add', name, 'netns', namespace, 'type', 'veth',
                            'peer', 'name', peer, 'netns', peer_namespace)
        if result.returncode != 0:
            pytest.skip(f'cannot create a veth pair: {result.stderr.strip()}')

    @staticmethod
    def _sh(namespace, script):
        result = subprocess.run(['ip', 'netns', 'exec', namespace, 'sh', '-c', script],
                                capture_output=True, text=True, timeout=20)
        assert result.returncode == 0, (namespace, script, result.stderr)

    @staticmethod
    def _step(namespace, *step):
        result = ip_command('-n', namespace, *step)
        assert result.returncode == 0, (namespace, step, result.stderr)

    def _configure(self, namespace, veth, address):
        # No IPv6 on the veth: its neighbour discovery would add packets that are not DDS.
        # (A kernel without IPv6 has no such file, and nothing to turn off.)
        self._sh(namespace, f'f=/proc/sys/net/ipv6/conf/{veth}/disable_ipv6; '
                            '[ ! -e $f ] || echo 1 > $f')
        for step in (('addr', 'add', address, 'dev', veth), ('link', 'set', 'lo', 'up'),
                     ('link', 'set', veth, 'up')):
            self._step(namespace, *step)

    def counters(self):
        """``{(side, 'rx_packets'): n, ...}`` of both sides' interfaces, read inside them."""
        counts = {}
        for side in (PANEL_SIDE, PEER_SIDE):
            for name in ('rx_packets', 'tx_packets', 'rx_bytes'):
                statistics = f'/sys/class/net/{self.veths[side]}/statistics/{name}'
                counts[side, name] = int(self.run(side, 'cat', statistics).stdout)
        return counts

    def _route(self, side):
        """Give a routed side its default route through the router (one subnet needs none)."""
        if self.routed:
            gateway = f'{self.addresses[side].rsplit(".", 1)[0]}.254'
            self._step(self.namespaces[side], 'route', 'replace', 'default', 'via', gateway)

    def set_up(self, side, up):
        self._step(self.namespaces[side], 'link', 'set', self.veths[side],
                   'up' if up else 'down')
        if up:  # the link's routes went with it
            self._route(side)
            self.wait_running(side)

    def report(self):
        """Describe both sides' networks as they are now, for a failure's message."""
        lines = []
        for side in (PANEL_SIDE, PEER_SIDE):
            for command in (('ip', '-s', 'link', 'show', self.veths[side]), ('ip', 'route'),
                            ('ss', '-uan')):
                result = self.run(side, *command)
                lines += [f'--- {self.namespaces[side]}: {" ".join(command)}',
                          result.stdout.strip() or result.stderr.strip()]
        if self.routed:
            forwarding = subprocess.run(
                ['ip', 'netns', 'exec', self.router, 'cat', '/proc/sys/net/ipv4/ip_forward'],
                capture_output=True, text=True, timeout=20)
            lines.append(f'--- {self.router}: ip_forward {forwarding.stdout.strip()}')
        return '\n'.join(lines)


@pytest.fixture(params=['multicast', 'static_peers'])
def link(request):
    """Fresh namespaces and links for one network, deleted afterwards whatever happened."""
    skip_without_namespaces()
    link = Link(f'ff{os.getpid()}{request.param[0]}', request.param)
    try:
        link.create()
        yield link
    finally:
        link.delete()


class Samples:
    """What the peer printed: its samples by topic and panel, in arrival order."""

    def __init__(self, peer):
        self.peer = peer

    def events(self):
        for line in list(self.peer.lines):
            if line.startswith('{'):
                yield json.loads(line)

    def of(self, topic, panel=None):
        return [event for event in self.events() if event.get('topic') == topic
                and panel in (None, event['panel'])]

    def every_panel_has(self, *topics):
        return all(self.of(topic, panel) for topic in topics for panel in PANELS)

    def latest(self, topic, panel):
        found = self.of(topic, panel)
        return found[-1]['value'] if found else None


def dds_environment(link, side):
    """Give each side one domain, Fast DDS on UDPv4 only, and the link's discovery."""
    env = {name: value for name, value in os.environ.items()
           if not name.startswith(('ROS_', 'RMW_', 'FASTDDS_', 'FASTRTPS_'))}
    # 40 is congruent to test_panel_node's 0 modulo domain_for's 40, but nothing outside these
    # namespaces can reach a participant inside them.
    env.update(ROS_DOMAIN_ID=str(domain_for(40)), RMW_IMPLEMENTATION='rmw_fastrtps_cpp',
               FASTDDS_BUILTIN_TRANSPORTS='UDPv4', PYTHONUNBUFFERED='1',
               RCUTILS_COLORIZED_OUTPUT='0',
               # Not LOCALHOST with static peers: for it rmw_fastrtps sets its own transports,
               # shared memory included, and FASTDDS_BUILTIN_TRANSPORTS has no effect.
               ROS_AUTOMATIC_DISCOVERY_RANGE='SUBNET')
    if link.discovery == 'static_peers':
        env['ROS_STATIC_PEERS'] = link.addresses[1 - side]
    return env


def test_states_and_setpoints_cross_the_link_between_two_hosts(link):
    started = time.monotonic()
    before = link.counters()
    panels = Child(link, PANEL_SIDE,
                   [str(BIN / 'panel_group'), '--panels', ','.join(PANELS), '--ros-args',
                    '-p', 'setpoint_timeout_s:=30.0'],
                   dds_environment(link, PANEL_SIDE))
    peer = None
    try:
        peer = Child(link, PEER_SIDE, [sys.executable, str(PEER), ','.join(PANELS)],
                     dds_environment(link, PEER_SIDE), stdin=True)
        assert panels.wait_for(lambda: any('ready' in line for line in panels.lines), 90.0), \
            panels.output()
        ready_s = time.monotonic() - started
        samples = Samples(peer)

        # States cross: every panel's latched status, closure and joint states, before any
        # setpoint has been sent.
        assert peer.wait_for(lambda: samples.every_panel_has('status', 'closure',
                                                             'joint_states'), 30.0), \
            (peer.output(), panels.output(), link.counters(), link.report())
        discovered_s = time.monotonic() - started
        for panel in PANELS:
            assert samples.of('status', panel)[0]['value'] == 'waiting_for_setpoint'
            assert samples.latest('closure', panel) < 0.05
            names, positions = samples.of('joint_states', panel)[-1]['value']
            assert names == list(contract.flap_joint_names(panel)) and len(positions) == 2

        # A setpoint crosses the other way and moves the panels.
        peer.tell(f'send {SETPOINT}')

        def moved():
            return all(samples.latest('status', p) == 'tracking'
                       and samples.latest('closure', p) > PASSED for p in PANELS)
        assert peer.wait_for(moved, 30.0), (peer.output(), panels.output())
        moved_s = time.monotonic() - started
        after = link.counters()

        # Over the veth, not shared memory: neither process mapped a Fast DDS segment, and the
        # peer's end received at least a packet per sample it printed.
        assert shared_memory_mappings(panels.pid) == []
        assert shared_memory_mappings(peer.pid) == []
        received = after[PEER_SIDE, 'rx_packets'] - before[PEER_SIDE, 'rx_packets']
        sent = after[PANEL_SIDE, 'rx_packets'] - before[PANEL_SIDE, 'rx_packets']
        crossed = len(samples.of('closure')) + len(samples.of('joint_states'))
        assert received >= crossed > 20, (received, crossed)
        assert sent > 20, sent

        # With the link down nothing crosses; up again, the states come back.
        link.set_up(PANEL_SIDE, False)
        # samples already through (in the peer's pipe) may still be printed: wait until
        # none has come for DOWN_GRACE_S (a loaded machine prints late), at most 30 s
        count_down, settle_until = -1, time.monotonic() + 30.0
        while count_down != len(samples.of('closure')) and time.monotonic() < settle_until:
            count_down = len(samples.of('closure'))
            time.sleep(DOWN_GRACE_S)
        time.sleep(DOWN_S)
        crossed_down = len(samples.of('closure')) - count_down
        link.set_up(PANEL_SIDE, True)
        up_again = time.monotonic()
        assert crossed_down == 0, crossed_down
        assert peer.wait_for(lambda: len(samples.of('closure')) > count_down + 2 * len(PANELS),
                             20.0), peer.output()
        closures = ', '.join(f'{samples.latest("closure", p):.2f}' for p in PANELS)
        print(f'\n{link.discovery}: {len(PANELS)} panels ready after {ready_s:.1f} s, '
              f'discovered at {discovered_s:.1f} s, closure past {PASSED} at {moved_s:.1f} s '
              f'({closures}); '
              f'{crossed} state samples crossed in {received} packets '
              f'({after[PEER_SIDE, "rx_bytes"] - before[PEER_SIDE, "rx_bytes"]} bytes), '
              f'{sent} packets the other way; link down {DOWN_S:.0f} s: {crossed_down} '
              f'samples; back {time.monotonic() - up_again:.1f} s after link up')
    finally:
        codes = [child.stop() for child in (peer, panels) if child is not None]
    assert codes == [0] * len(codes), (codes, panels.output(), peer and peer.output())
