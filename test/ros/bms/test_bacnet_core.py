"""The BACnet core without ROS: the priority mapping, the bounds, and the application.

The application is exercised over the loopback by bacpypes3's own client ``Application``
(Who-Is, ReadProperty, WriteProperty, SubscribeCOV), the way a BMS would: the gateway and the
client each bind 127.0.0.1/32 on a port of their own (two apps on one ip:port clash).
"""

import asyncio
from contextlib import asynccontextmanager
import math
import socket
import time

from bacpypes3.apdu import ErrorRejectAbortNack, WritePropertyRequest
from bacpypes3.app import Application
from bacpypes3.errors import UnrecognizedService
from bacpypes3.pdu import Address
from bacpypes3.primitivedata import CharacterString, Null, ObjectIdentifier, Unsigned
import pytest

from flectofold_ros.bms.gateway import (check_bindable, check_device_name, FacadeGateway,
                                        MAX_NAME_CHARS, parse_address)
from flectofold_ros.bms.objects import FacadeObjects
from flectofold_ros.bms.priority import (check_closure_percent, check_command, check_priority,
                                         CommandSlots, effective_override, Refused)

PANELS = ['r00c00', 'r00c01', 'r01c00']
INSTANCE = 4100
#: Wall seconds within which an answer or a notification comes on the loopback; a bound
#: against a hang, not a time the test judges.
ANSWER_S = 10.0


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(('127.0.0.1', 0))
        return probe.getsockname()[1]


def client_application(port):
    """bacpypes3's client, on a port of its own (unicast only: a /32 has no broadcast)."""
    from argparse import Namespace
    return Application.from_args(Namespace(
        name='bms-client', instance=4200, address=f'127.0.0.1/32:{port}', network=0,
        vendoridentifier=999, foreign=None, ttl=30, bbmd=None))


class Handed:
    """What the gateway handed on: overrides and clears, in order."""

    def __init__(self):
        self.overrides, self.clears = [], []


@asynccontextmanager
async def facade_and_client():
    handed = Handed()
    port = free_udp_port()
    gateway = FacadeGateway.create(PANELS, parse_address(f'127.0.0.1/32:{port}'), INSTANCE,
                                   'facade-test', on_override=handed.overrides.append,
                                   on_clear=handed.clears.append)
    client = client_application(free_udp_port())
    try:
        yield gateway, client, Address(f'127.0.0.1:{port}'), handed
    finally:
        client.close()
        gateway.close()


def run(test):
    """Run ``test(gateway, client, address, handed)`` in a fresh asyncio loop."""
    async def body():
        async with facade_and_client() as parts:
            await asyncio.wait_for(test(*parts), 60.0)
    asyncio.run(body())


async def write(client, address, value, priority=8, obj='analog-value,1'):
    return await client.write_property(address, obj, 'present-value', value, priority=priority)


async def refusal(call):
    """Return the BACnet error code of an awaited request that must fail."""
    with pytest.raises(ErrorRejectAbortNack) as error:
        await call
    return str(error.value.errorCode)


async def notified(subscription, prop):
    """Return the values of ``prop`` notified up to and including its next notification."""
    values = []
    while True:
        name, value = await asyncio.wait_for(subscription.get_value(), ANSWER_S)
        if str(name) == prop:
            values.append(value)
            return values


# -- the priority mapping and the bounds, pure ----------------------------------------------

def test_a_priority_is_taken_from_1_to_16_and_refused_just_outside():
    assert check_priority(1) == 1 and check_priority(16) == 16
    assert check_priority(None) == 16  # ASHRAE 135 19.2: no priority writes at 16
    for priority in (0, 17, -1, 1.5, True):
        with pytest.raises(Refused) as refused:
            check_priority(priority)
        assert refused.value.error_code == 'parameterOutOfRange', priority


def test_a_closure_command_is_taken_from_0_to_100_percent_and_refused_just_beyond():
    assert check_closure_percent(0.0) == 0.0 and check_closure_percent(100) == 100.0
    for value in (-1e-9, 100.0 + 1e-9, math.nan, math.inf, -math.inf):
        with pytest.raises(Refused) as refused:
            check_closure_percent(value)
        assert refused.value.error_code == 'valueOutOfRange', value
    for value in ('50', True, None, [50.0]):
        with pytest.raises(Refused) as refused:
            check_closure_percent(value)
        assert refused.value.error_code == 'invalidDataType', value


def test_a_value_at_priority_8_is_an_override_and_at_9_is_refused_as_automatic():
    assert check_command(42.0, 8, storm_latched=False) == (8, 42.0)
    assert check_command(42.0, 1, storm_latched=False) == (1, 42.0)
    for priority in (9, 16, None):
        with pytest.raises(Refused) as refused:
            check_command(42.0, priority, storm_latched=False)
        assert refused.value.error_code == 'writeAccessDenied'
        assert 'automatic' in refused.value.reason


def test_in_a_storm_a_value_at_every_priority_is_refused_but_a_relinquish_is_taken():
    for priority in range(1, 9):
        with pytest.raises(Refused) as refused:
            check_command(42.0, priority, storm_latched=True)
        assert 'storm latch set' in refused.value.reason
        assert check_command(None, priority, storm_latched=True) == (priority, None)


def test_the_highest_slot_wins_and_a_panel_command_outranks_the_facade_command():
    panel, facade = CommandSlots(), CommandSlots()
    assert effective_override(panel, facade) is None
    facade.write(8, 30.0)
    assert effective_override(panel, facade) == pytest.approx(0.3)
    panel.write(8, 60.0)
    panel.write(3, 10.0)
    assert effective_override(panel, facade) == pytest.approx(0.1)
    panel.write(3, None)
    assert effective_override(panel, facade) == pytest.approx(0.6)
    assert panel.relinquish_overrides() == 1
    assert effective_override(panel, facade) == pytest.approx(0.3)


def test_the_object_table_numbers_each_panel_and_refuses_a_facade_it_cannot_number():
    async def body():  # bacpypes3 objects finish their set-up in the running loop
        table = FacadeObjects(PANELS)
        identifiers = {tuple(o.objectIdentifier) for o in table.objects}
        assert len(identifiers) == len(table.objects) == 2 + 4 * len(PANELS)
        FacadeObjects([f'r{i // 100:02d}c{i % 100:02d}' for i in range(999)])
        with pytest.raises(ValueError, match='1..999'):
            FacadeObjects([f'r{i // 100:02d}c{i % 100:02d}' for i in range(1000)])
        with pytest.raises(ValueError):
            FacadeObjects([])
        await asyncio.sleep(0.1)  # let the objects' set-up tasks finish
    asyncio.run(body())


def test_the_gateway_binds_the_loopback_only_unless_told():
    assert parse_address('127.0.0.1/32:47808').addrTuple == ('127.0.0.1', 47808)
    for text in ('10.0.0.5/24:47808', '0.0.0.0/0:47808', '127.0.0.1/32:0',
                 '127.0.0.1/32:65536', '127.0.0.1', 'host'):
        with pytest.raises(ValueError):
            parse_address(text)
    assert parse_address('10.0.0.5/24:47808', allow_any_address=True).addrTuple == \
        ('10.0.0.5', 47808)


def test_a_device_name_is_taken_from_1_to_64_printable_characters():
    assert check_device_name('x') == 'x'
    assert check_device_name('n' * MAX_NAME_CHARS) == 'n' * MAX_NAME_CHARS
    for name in ('', 'n' * (MAX_NAME_CHARS + 1), 'facade\n', 'a\x00b', 7):
        with pytest.raises(ValueError, match='printable'):
            check_device_name(name)


def test_a_port_another_application_holds_is_refused_at_start():
    port = free_udp_port()
    address = parse_address(f'127.0.0.1/32:{port}')
    check_bindable(address)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as holder:
        holder.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)  # as bacpypes3 binds
        holder.bind(('127.0.0.1', port))
        with pytest.raises(ValueError, match='cannot be bound'):
            check_bindable(address)
    with pytest.raises(ValueError, match='cannot be bound'):
        check_bindable(parse_address('192.0.2.1/32:47808', allow_any_address=True))


# -- the application, through bacpypes3's client ----------------------------------------------

def test_who_is_finds_the_device_and_its_objects_read_back():
    async def test(gateway, client, address, handed):
        i_ams = await client.who_is(INSTANCE, INSTANCE, address)
        assert [tuple(i.iAmDeviceIdentifier) for i in i_ams] == [('device', INSTANCE)] or \
            [i.iAmDeviceIdentifier[1] for i in i_ams] == [INSTANCE]
        assert await client.who_is(INSTANCE + 1, INSTANCE + 1, address, timeout=1.0) == []
        objects = await client.read_property(address, f'device,{INSTANCE}', 'object-list')
        assert len(objects) == 2 + 2 + 4 * len(PANELS)  # device, network port, the table
        name = await client.read_property(address, 'analog-value,2', 'object-name')
        assert str(name) == 'r00c01 closure command'
        slots = await client.read_property(address, 'analog-value,1', 'priority-array')
        assert [s.null for s in slots] == [()] * 16
        assert str(await client.read_property(address, 'analog-value,1', 'units')) == 'percent'
        assert str(await client.read_property(address, 'analog-input,1001', 'units')) == \
            'pascals'
        states = await client.read_property(address, 'multi-state-input,1', 'state-text')
        assert [str(s) for s in states][0] == 'none'
        assert str(await client.read_property(address, 'binary-input,0', 'present-value')) == \
            'inactive'
    run(test)


def test_the_device_reports_the_services_it_executes_and_rejects_the_others():
    async def test(gateway, client, address, handed):
        services = await client.read_property(address, f'device,{INSTANCE}',
                                              'protocol-services-supported')
        assert set(str(services).split(';')) == {
            'read-property', 'read-property-multiple', 'write-property', 'subscribe-cov',
            'read-range', 'who-is', 'who-has'}
        assert str(await client.read_property(address, f'device,{INSTANCE}',
                                              'protocol-revision')) == '22'
        values = await client.read_property_multiple(
            address, ['analog-value,1', ['present-value', 'units']])
        assert [(str(p), v) for _, p, _, v in values][0] == ('present-value', 0.0)
        for service in ('WritePropertyMultiple', 'DeviceCommunicationControl'):
            with pytest.raises(UnrecognizedService):
                await getattr(gateway, f'do_{service}Request')(None)
        assert gateway.refused == {'unrecognizedService': 2}
    run(test)


def test_a_write_at_priority_8_is_handed_on_as_an_override_and_relinquished_as_a_clear():
    async def test(gateway, client, address, handed):
        gateway.set_automatic('r00c00', 0.9)
        assert await client.read_property(address, 'analog-value,1', 'present-value') == \
            pytest.approx(90.0)
        assert await write(client, address, 42.0) is None
        assert handed.overrides == [{'r00c00': pytest.approx(0.42)}]
        assert await client.read_property(address, 'analog-value,1', 'present-value') == \
            pytest.approx(42.0)
        priority = await client.read_property(address, 'analog-value,1',
                                              'current-command-priority')
        assert priority.unsigned == 8
        assert await write(client, address, 10.0, priority=3) is None  # outranks 8
        assert handed.overrides[-1] == {'r00c00': pytest.approx(0.10)}
        assert await write(client, address, Null(()), priority=3) is None
        assert handed.overrides[-1] == {'r00c00': pytest.approx(0.42)}
        assert await write(client, address, Null(())) is None
        assert handed.clears == [['r00c00']]
        assert await client.read_property(address, 'analog-value,1', 'present-value') == \
            pytest.approx(90.0)  # the relinquish default: the coordinator's command
        assert gateway.writes_accepted == 4
    run(test)


def test_the_facade_command_overrides_every_panel_below_their_own():
    async def test(gateway, client, address, handed):
        await write(client, address, 80.0, obj='analog-value,2')
        await write(client, address, 20.0, obj='analog-value,0')
        assert handed.overrides[-1] == {'r00c00': pytest.approx(0.2), 'r01c00': pytest.approx(0.2)}
        await write(client, address, Null(()), obj='analog-value,0')
        assert sorted(handed.clears[-1]) == ['r00c00', 'r01c00']
        assert gateway.overrides['r00c01'] == pytest.approx(0.8)
    run(test)


def test_each_bound_of_a_write_is_taken_at_the_bound_and_refused_just_beyond():
    async def test(gateway, client, address, handed):
        assert await write(client, address, 0.0) is None
        assert await write(client, address, 100.0) is None
        assert await write(client, address, 50.0, priority=1) is None
        for value in (-0.001, 100.001, math.nan, math.inf):
            assert await refusal(write(client, address, value)) == 'value-out-of-range', value
        assert await refusal(write(client, address, 50.0, priority=9)) == 'write-access-denied'
        assert await refusal(write(client, address, 50.0, priority=16)) == 'write-access-denied'
        assert await refusal(write(client, address, 50.0, priority=None)) == \
            'write-access-denied'  # no priority is 16
        assert await refusal(write(client, address, 50.0, priority=0)) == \
            'parameter-out-of-range'
        assert await refusal(write(client, address, 50.0, priority=17)) == \
            'parameter-out-of-range'
        request = WritePropertyRequest(
            objectIdentifier=ObjectIdentifier('analog-value,1'), propertyIdentifier='presentValue',
            propertyValue=CharacterString('half'), destination=address, priority=8)
        assert await refusal(client.request(request)) == 'invalid-data-type'
        request = WritePropertyRequest(  # an Unsigned is not a REAL either
            objectIdentifier=ObjectIdentifier('analog-value,1'), propertyIdentifier='presentValue',
            propertyValue=Unsigned(50), destination=address, priority=8)
        assert await refusal(client.request(request)) == 'invalid-data-type'
        assert await refusal(write(client, address, 1.0, obj='analog-value,4')) == \
            'unknown-object'
        assert await refusal(write(client, address, 1.0, obj='analog-input,1')) == \
            'write-access-denied'
        assert await refusal(client.write_property(
            address, 'analog-value,1', 'relinquish-default', 1.0)) == 'write-access-denied'
        assert await refusal(client.read_property(address, 'analog-value,9', 'present-value')) \
            == 'unknown-object'
        assert await refusal(client.read_property(address, 'analog-input,1', 'priority-array')) \
            == 'unknown-property'
        assert gateway.refused == {'valueOutOfRange': 4, 'writeAccessDenied': 5,
                                   'parameterOutOfRange': 2, 'invalidDataType': 2,
                                   'unknownObject': 2, 'unknownProperty': 1}
        assert handed.overrides[-1] == {'r00c00': pytest.approx(0.5)}  # the refused left it
    run(test)


def test_in_a_storm_a_write_is_refused_the_slots_end_and_the_latch_object_alarms():
    async def test(gateway, client, address, handed):
        await write(client, address, 42.0)
        gateway.set_storm(True)
        assert gateway.slots_ended_by_storm == 1
        slots = await client.read_property(address, 'analog-value,1', 'priority-array')
        assert [s.null for s in slots] == [()] * 16
        assert str(await client.read_property(address, 'binary-input,0', 'present-value')) == \
            'active'
        assert str(await client.read_property(address, 'binary-input,0', 'event-state')) == \
            'offnormal'
        flags = await client.read_property(address, 'binary-input,0', 'status-flags')
        assert flags[0] == 1  # in-alarm
        for priority in (1, 8):
            assert await refusal(write(client, address, 42.0, priority=priority)) == \
                'write-access-denied'
        assert 'storm latch set' in gateway.last_refusal
        assert await write(client, address, Null(())) is None  # a relinquish is taken
        assert handed.overrides == [{'r00c00': pytest.approx(0.42)}] and handed.clears == []
        gateway.set_storm(False)
        assert await write(client, address, 42.0) is None
        assert str(await client.read_property(address, 'binary-input,0', 'event-state')) == \
            'normal'
    run(test)


def test_cov_notifications_come_for_a_change_of_the_increment_and_not_for_less():
    async def test(gateway, client, address, handed):
        gateway.set_panel_state('r00c00', 0.50, 101325.0, 'none')
        async with client.change_of_value(address, ObjectIdentifier('analog-input,1'), 7, True,
                                          60) as subscription:
            initial = await notified(subscription, 'present-value')
            assert initial == [pytest.approx(50.0)]  # the initial notification
            gateway.set_panel_state('r00c00', 0.505, 101325.0, 'none')  # 0.5 %: below 1 %
            started = time.monotonic()
            gateway.set_panel_state('r00c00', 0.52, 101325.0, 'none')  # 2 % from the last sent
            values = await notified(subscription, 'present-value')
            latency_s = time.monotonic() - started
            assert values == [pytest.approx(52.0)]
            print(f'COV on the loopback, in one process: {latency_s * 1e3:.1f} ms')
        async with client.change_of_value(address, ObjectIdentifier('multi-state-input,1'), 8,
                                          True, 60) as subscription:
            assert await notified(subscription, 'present-value') == [1]
            gateway.set_panel_state('r00c00', 0.52, 101325.0, 'leak')
            assert await notified(subscription, 'present-value') == [4]  # 1 + index of leak
        assert str(await client.read_property(address, 'multi-state-input,1', 'event-state')) \
            == 'offnormal'
    run(test)


def test_inputs_without_data_are_unreliable_until_a_state_and_after_it_goes_stale():
    async def test(gateway, client, address, handed):
        assert str(await client.read_property(address, 'analog-input,1', 'reliability')) == \
            'communication-failure'
        gateway.set_panel_state('r00c00', 0.25, math.nan, 'none')
        assert str(await client.read_property(address, 'analog-input,1', 'reliability')) == \
            'no-fault-detected'
        assert str(await client.read_property(address, 'analog-input,1001', 'reliability')) == \
            'no-sensor'
        gateway.mark_stale('r00c00')
        assert str(await client.read_property(address, 'analog-input,1', 'reliability')) == \
            'communication-failure'
        flags = await client.read_property(address, 'analog-input,1', 'status-flags')
        assert flags[1] == 1  # fault
    run(test)
