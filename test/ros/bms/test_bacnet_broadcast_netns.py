"""A broadcast Who-Is between two network namespaces: a BMS discovering the gateway on a subnet.

On the loopback the gateway and the client bind 127.0.0.1/32 (no broadcast) and the client
asks the gateway's address. Here the test makes two network namespaces joined by a veth pair
on 10.47.8.0/24, two hosts of a site subnet: the gateway's application at 10.47.8.1/24 in one,
bacpypes3's client at 10.47.8.2/24 in the other, both on port 47808. A Who-Is sent to the
subnet's broadcast address (bacpypes3's client sends it as a global broadcast) finds the
gateway in its instance range and nothing outside it. No ROS. Needs root and ``ip netns``;
skipped otherwise. Nothing binds outside the namespaces.
"""

import json
import os
from pathlib import Path
import subprocess
import sys

from netns import ip_command, skip_without_namespaces
import pytest

ROOT = Path(__file__).resolve().parents[3]
NAMESPACES = (f'flectofold-bms-{os.getpid()}', f'flectofold-gw-{os.getpid()}')
CLIENT, GATEWAY = '10.47.8.2', '10.47.8.1'
#: The gateway's application, serving until its standard input closes.
SERVE = f"""
import asyncio, sys
from flectofold_ros.bms.gateway import FacadeGateway, parse_address

async def main():
    gateway = FacadeGateway.create(['r00c00', 'r00c01'],
                                   parse_address('{GATEWAY}/24:47808', allow_any_address=True),
                                   4100, 'facade-netns')
    print('serving', flush=True)
    await asyncio.get_running_loop().run_in_executor(None, sys.stdin.read)
    gateway.close()

asyncio.run(main())
"""
#: The BMS: a broadcast Who-Is in and out of the gateway's range, a read of what it found.
ASK = f"""
import asyncio, json
from argparse import Namespace
from bacpypes3.app import Application

async def main():
    client = Application.from_args(Namespace(
        name='bms', instance=4200, address='{CLIENT}/24:47808', network=0,
        vendoridentifier=999, foreign=None, ttl=30, bbmd=None))
    found = []
    for _ in range(10):  # the gateway's endpoints may still be binding
        found = await client.who_is(4000, 4199, timeout=2.0)
        if found:
            break
    others = await client.who_is(5000, 5999, timeout=2.0)
    name = await client.read_property(found[0].pduSource, 'device,4100', 'object-name')
    print(json.dumps({{'found': [[str(i.pduSource), i.iAmDeviceIdentifier[1]] for i in found],
                      'others': len(others), 'name': str(name)}}))
    client.close()

asyncio.run(main())
"""


@pytest.fixture
def subnet():
    skip_without_namespaces()
    for namespace in NAMESPACES:
        ip_command('netns', 'delete', namespace, timeout_s=30)
        added = ip_command('netns', 'add', namespace, timeout_s=30)
        if added.returncode != 0:
            pytest.skip(f'ip netns add failed: {added.stderr.strip()}')
    client_ns, gateway_ns = NAMESPACES
    try:
        steps = [('link', 'add', 'bac0', 'netns', client_ns, 'type', 'veth', 'peer', 'name',
                  'bac1', 'netns', gateway_ns)]
        for namespace, address, device in ((client_ns, CLIENT, 'bac0'),
                                           (gateway_ns, GATEWAY, 'bac1')):
            steps += [('-n', namespace, 'link', 'set', 'lo', 'up'),
                      ('-n', namespace, 'addr', 'add', f'{address}/24', 'brd', '+', 'dev',
                       device),
                      ('-n', namespace, 'link', 'set', device, 'up')]
        for step in steps:
            result = ip_command(*step, timeout_s=30)
            assert result.returncode == 0, (step, result.stderr)
        yield NAMESPACES
    finally:
        for namespace in NAMESPACES:
            ip_command('netns', 'delete', namespace, timeout_s=30)


def test_a_broadcast_who_is_on_a_subnet_finds_the_gateway(subnet):
    client_ns, gateway_ns = subnet
    server = subprocess.Popen(['ip', 'netns', 'exec', gateway_ns, sys.executable, '-c', SERVE],
                              cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
    try:
        assert server.stdout.readline().strip() == 'serving'
        ask = subprocess.run(['ip', 'netns', 'exec', client_ns, sys.executable, '-c', ASK],
                             cwd=ROOT, capture_output=True, text=True, timeout=120)
    finally:
        output = server.communicate(input='', timeout=30)[0]
    assert ask.returncode == 0, ask.stderr[-3000:] + output[-2000:]
    result = json.loads(ask.stdout.strip().splitlines()[-1])
    assert result == {'found': [[GATEWAY, 4100]], 'others': 0, 'name': 'facade-netns'}, result
