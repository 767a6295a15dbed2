"""A site network with mutual TLS: site hosts talk, a foreign certificate, UDP and TCP do not.

Two network namespaces of this kernel joined by one veth pair: the panels' host (10.213.70.1)
and the other side, which holds four addresses: the site's commanding peer (.2, a certificate
of the site CA), a host with a certificate of a *foreign* CA (.3), a plain TCP peer (.4, the
same TCP transport without TLS) and a plain UDP peer (.5, Fast DDS's UDPv4 with
``ROS_STATIC_PEERS`` pointing at the panels). The site hosts run on the profiles
``site_certificates`` made (:mod:`flectofold_ros.sitenet`). The rogues publish setpoints of
their own from the start; the site peer sends its own only later. ``msg_docs/security.md``
says what this shows and what it does not. Needs root and ``ip netns``; skipped otherwise.
"""

import os
from pathlib import Path
import subprocess
import sys
import time

from netns import (Child, ip_command, shared_memory_mappings, skip_without_namespaces,
                   WAIT_RUNNING)
import pytest
from ros_graph import BIN, domain_for

from flectofold_ros.sitenet import certificates, fastdds_profile

pytestmark = pytest.mark.graph

ROOT = Path(__file__).resolve().parents[3]
PEER = ROOT / 'test' / 'helpers' / 'dds_peer.py'
PANELS = ('r00c00', 'r00c01')
PANEL_IP, PEER_IP, FOREIGN_IP, TCP_IP, UDP_IP = (f'10.213.70.{k}' for k in range(1, 6))
PORT = 45100
#: The site peer's setpoint and the closure the panels must pass; the rogues' setpoint.
SETPOINT, PASSED, ROGUE_SETPOINT = 0.8, 0.3, 0.2
#: Wall seconds the rogues command alone after the site peer first sees every panel's state.
ROGUES_ALONE_S = 5.0
BITS = 2048


class Network:
    """Namespace 0 (the panels' host) and 1 (everyone else), one veth between them."""

    def __init__(self, tag):
        self.namespaces = (f'{tag}s', f'{tag}o')
        self.veths = (f'{tag}vs', f'{tag}vo')
        self.made = []

    def create(self):
        for namespace in self.namespaces:
            ip_command('netns', 'delete', namespace)  # a leftover of a killed run with this pid
            result = ip_command('netns', 'add', namespace)
            if result.returncode != 0:
                pytest.skip(f'ip netns add failed: {result.stderr.strip()}')
            self.made.append(namespace)
        result = ip_command('link', 'add', self.veths[0], 'netns', self.namespaces[0],
                            'type', 'veth', 'peer', 'name', self.veths[1], 'netns',
                            self.namespaces[1])
        if result.returncode != 0:
            pytest.skip(f'cannot create a veth pair: {result.stderr.strip()}')
        addresses = ([PANEL_IP], [PEER_IP, FOREIGN_IP, TCP_IP, UDP_IP])
        for side in (0, 1):
            steps = [('link', 'set', 'lo', 'up')]
            steps += [('addr', 'add', f'{address}/24', 'dev', self.veths[side])
                      for address in addresses[side]]
            steps.append(('link', 'set', self.veths[side], 'up'))
            for step in steps:
                result = ip_command('-n', self.namespaces[side], *step)
                assert result.returncode == 0, (step, result.stderr)
        for side in (0, 1):
            result = self.run(side, sys.executable, '-c', WAIT_RUNNING, self.veths[side], '10')
            assert result.returncode == 0, result.stdout + result.stderr

    def run(self, side, *command):
        return subprocess.run(['ip', 'netns', 'exec', self.namespaces[side], *command],
                              capture_output=True, text=True, timeout=20)

    def delete(self):
        for namespace in self.made:
            ip_command('netns', 'delete', namespace)


@pytest.fixture
def network():
    skip_without_namespaces()
    network = Network(f'fs{os.getpid()}')
    try:
        network.create()
        yield network
    finally:
        network.delete()


@pytest.fixture
def profiles(tmp_path):
    """Profiles: the panels' and the peer's (site CA), the foreign host's, the plain TCP one."""
    site, foreign = tmp_path / 'site', tmp_path / 'foreign'
    certificates.make_authority(site, bits=BITS)
    certificates.make_authority(foreign, name='another site CA', bits=BITS)
    made = {}
    for directory, name, ip, peer in ((site, 'panels-1', PANEL_IP, PEER_IP),
                                      (site, 'peer-1', PEER_IP, PANEL_IP),
                                      (foreign, 'peer-1', FOREIGN_IP, PANEL_IP)):
        certificates.make_host(directory, name, ip, bits=BITS)
        path = directory / f'{name}.xml'
        path.write_text(fastdds_profile.host_profile(directory, name, ip, PORT, [(peer, PORT)]))
        made[directory.name, name] = fastdds_profile.check_profile(path)
    # the same transport without TLS: what a stranger who read the profile could run
    text = (site / 'peer-1.xml').read_text().replace(PEER_IP, TCP_IP)
    start, end = text.index('      <tls>'), text.index('</tls>') + len('</tls>\n')
    plain = tmp_path / 'plain_tcp.xml'
    plain.write_text(text[:start] + text[end:])
    made['plain_tcp'] = plain
    return made


def environment(profile=None, **extra):
    """One domain; a site profile (as ``facade --site-profile`` sets it) or plain UDPv4."""
    env = {name: value for name, value in os.environ.items()
           if not name.startswith(('ROS_', 'RMW_', 'FASTDDS_', 'FASTRTPS_'))}
    env.update(ROS_DOMAIN_ID=str(domain_for(60)), PYTHONUNBUFFERED='1',
               RCUTILS_COLORIZED_OUTPUT='0', **extra)
    if profile is None:
        env.update(RMW_IMPLEMENTATION='rmw_fastrtps_cpp', FASTDDS_BUILTIN_TRANSPORTS='UDPv4',
                   ROS_AUTOMATIC_DISCOVERY_RANGE='SUBNET', ROS_STATIC_PEERS=PANEL_IP)
        return env
    return fastdds_profile.site_environment(profile, env)


def test_site_hosts_command_the_panels_over_tls_and_strangers_see_and_move_nothing(
        network, profiles):
    panels = Child(network, 0, [str(BIN / 'panel_group'), '--panels', ','.join(PANELS),
                                '--ros-args', '-p', 'setpoint_timeout_s:=60.0'],
                   environment(profiles['site', 'panels-1']))
    peers = {}
    try:
        peer_command = [sys.executable, str(PEER), ','.join(PANELS)]
        peers['site'] = Child(network, 1, peer_command,
                              environment(profiles['site', 'peer-1']), stdin=True)
        peers['foreign CA'] = Child(network, 1, peer_command,
                                    environment(profiles['foreign', 'peer-1']), stdin=True)
        peers['plain TCP'] = Child(network, 1, peer_command,
                                   environment(profiles['plain_tcp']), stdin=True)
        peers['plain UDP'] = Child(network, 1, peer_command, environment(), stdin=True)
        rogues = {name: peer for name, peer in peers.items() if name != 'site'}
        for name, peer in peers.items():
            assert peer.wait_for(lambda p=peer: any(e.get('event') == 'ready'
                                                    for e in p.events()), 90.0), \
                (name, peer.output())
        for rogue in rogues.values():
            rogue.tell(f'send {ROGUE_SETPOINT}')
        rogues_sending = time.monotonic()
        assert panels.wait_for(lambda: any('ready' in line for line in panels.lines), 120.0), \
            panels.output()
        panels_ready = time.monotonic()
        site = peers['site']

        # The site peer sees every panel's state; the panels still wait for a setpoint,
        # though the rogues have been sending theirs since they were ready.
        assert site.wait_for(lambda: all(site.samples(topic, panel) for panel in PANELS
                                         for topic in ('status', 'closure')), 60.0), \
            (site.output(), panels.output())
        # the same kernel's monotonic clock in every namespace
        first = min(event['t'] for event in site.samples())
        first_s, first_from_start_s = first - panels_ready, first - panels.started
        seen_all_s = time.monotonic() - panels_ready
        time.sleep(ROGUES_ALONE_S)
        for panel in PANELS:
            assert site.latest('status', panel) == 'waiting_for_setpoint', site.output()
            assert site.latest('closure', panel) < 0.05

        # The site peer's command moves them.
        site.tell(f'send {SETPOINT}')
        sent = time.monotonic()

        def moved():
            return all(site.latest('status', p) == 'tracking'
                       and site.latest('closure', p) > PASSED for p in PANELS)
        assert site.wait_for(moved, 60.0), (site.output(), panels.output())
        moved_s = time.monotonic() - sent

        # TLS only: the panel process has no UDP socket and no shared-memory segment.
        sockets = network.run(0, 'ss', '-uanp').stdout
        assert f'pid={panels.process.pid},' not in sockets, sockets
        assert shared_memory_mappings(panels.process.pid) == []
        seen = {name: len(rogue.samples()) for name, rogue in rogues.items()}
        assert seen == dict.fromkeys(rogues, 0), \
            {name: rogue.output() for name, rogue in rogues.items()}
        print(f'\nsite network: first state at the site peer {first_from_start_s:.1f} s '
              f'after the panel process started ({first_s:+.1f} s from the test reading its '
              f'ready line), every panel seen {seen_all_s:.1f} s after that line; closure past '
              f'{PASSED} {moved_s:.1f} s after the command; rogues commanding alone for '
              f'{sent - rogues_sending:.0f} s moved nothing; samples seen by the rogues: '
              f'{seen}; site peer samples {len(site.samples())}')
    finally:
        codes = {name: peer.stop() for name, peer in peers.items()}
        codes['panels'] = panels.stop()
    assert set(codes.values()) == {0}, (codes, panels.output())


def test_a_facade_on_a_site_profile_runs_its_day_and_a_site_peer_sees_both_panel_processes(
        network, profiles, tmp_path):
    """``facade --site-profile`` with two panel processes: one port per process, all meet.

    The facade host's processes (the bringup, two ``panel_group``) take ports 45100-45102;
    the peer's profile lists all three, as the guide says.
    """
    peer_profile = tmp_path / 'site' / 'peer-3.xml'
    peer_profile.write_text(fastdds_profile.host_profile(
        tmp_path / 'site', 'peer-1', PEER_IP, PORT, fastdds_profile.parse_peer(
            f'{PANEL_IP}:{PORT}-{PORT + 2}')))
    watched = ('r00c00', 'r05c05')  # one in each panel process
    facade = Child(network, 0, [str(BIN / 'facade'), '--start', '12:00', '--end', '12:30',
                                '--panel-processes', '2', '--progress-period', '2',
                                '--site-profile', str(profiles['site', 'panels-1'])],
                   environment())
    peer = None
    try:
        peer = Child(network, 1, [sys.executable, str(PEER), ','.join(watched)],
                     environment(peer_profile), stdin=True)
        assert facade.wait_for(lambda: facade.process.poll() is not None, 300.0), \
            facade.output()
        assert facade.process.returncode == 0, facade.output()
        output = ''.join(facade.lines)
        assert 'panels reporting: 36/36' in output, output
        assert 'TCP ports 45100-45102' in output, output
        seen = {panel: len(peer.samples('closure', panel)) for panel in watched}
        assert all(seen.values()), (seen, peer.output())
        print(f'\nfacade on a site profile: day finished; the site peer saw closure samples '
              f'{seen} from the two panel processes')
    finally:
        codes = [child.stop() for child in (peer, facade) if child is not None]
    assert set(codes) == {0}, (codes, facade.output())
