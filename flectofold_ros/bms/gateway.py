"""The BACnet application of the gateway: answers a BMS and hands its commands to callbacks.

:class:`FacadeGateway` is a bacpypes3 ``Application`` serving a
:class:`~flectofold_ros.bms.objects.FacadeObjects` table. A WriteProperty to a closure
command's ``present-value`` is checked (:func:`~flectofold_ros.bms.priority.check_command`),
written into the object's priority array, and each panel whose effective override changed is
handed to ``on_override({panel id: closure [0, 1]})`` or ``on_clear([panel id, ...])``. Every
refused request (a write or a read) is answered with its BACnet error, logged with the reason
and counted by error code in :attr:`FacadeGateway.refused`. Runs in one asyncio loop; the
update methods must be called in it.
"""

from argparse import Namespace
from collections import Counter
import ipaddress
import logging
import socket

from bacpypes3.apdu import SimpleAckPDU
from bacpypes3.app import Application
from bacpypes3.basetypes import PropertyIdentifier, ServicesSupported
from bacpypes3.errors import ExecutionError, UnrecognizedService
from bacpypes3.pdu import Address
from bacpypes3.primitivedata import Null, Real

from flectofold_ros.bms.objects import ALL_PANELS, FacadeObjects
from flectofold_ros.bms.priority import (check_command, CommandSlots, effective_override,
                                         Refused)

LOGGER = logging.getLogger('flectofold.bacnet_gateway')
#: The services the gateway executes, as its device object reports them (bacpypes3's own
#: introspection names services it does not execute, and reads unconfirmed ones as confirmed).
SERVICES = ('readProperty', 'readPropertyMultiple', 'writeProperty', 'subscribeCOV',
            'readRange', 'whoIs', 'whoHas')
#: Services bacpypes3 would execute that the gateway rejects (unrecognized-service): a
#: WritePropertyMultiple would write priority arrays past the checks here, and a
#: DeviceCommunicationControl without a password would let anyone silence the device.
REJECTED_SERVICES = ('WritePropertyMultiple', 'DeviceCommunicationControl')
#: bacpypes3's vendor identifier of sample applications (not assigned to this project; a
#: deployment needs the integrator's ASHRAE-assigned one): ``msg_docs/bacnet_gateway.md``.
VENDOR_IDENTIFIER = 999
#: What a loopback-only gateway may bind: 127.0.0.1 (network namespaces made by tests
#: aside, which pass ``allow_any_address``).
LOOPBACK = ipaddress.ip_address('127.0.0.1')


def parse_address(text, allow_any_address=False):
    """Return ``text`` (``a.b.c.d/prefix:port``) as a bacpypes3 ``Address``; ValueError if bad.

    Only 127.0.0.1 unless ``allow_any_address``; a port in 1..65535 is required.
    """
    try:
        host, _, port = text.rpartition(':')
        interface = ipaddress.ip_interface(host)
        port_number = int(port)
    except ValueError:
        raise ValueError(f'address {text!r} is not a.b.c.d/prefix:port') from None
    if interface.version != 4 or not 1 <= port_number <= 65535:
        raise ValueError(f'address {text!r}: an IPv4 address and a port in 1..65535')
    if interface.ip != LOOPBACK and not allow_any_address:
        raise ValueError(f'address {text!r}: the gateway binds 127.0.0.1 only unless told '
                         'that another address is wanted (allow_any_address)')
    return Address(f'{interface.ip}/{interface.network.prefixlen}:{port_number}')


#: Longest device name taken [characters].
MAX_NAME_CHARS = 64


def check_device_name(name):
    """Return ``name`` if it has 1 to :data:`MAX_NAME_CHARS` printable characters; ValueError."""
    if not isinstance(name, str) or not 1 <= len(name) <= MAX_NAME_CHARS \
            or not name.isprintable():
        raise ValueError(f'device name {name!r} must be 1 to {MAX_NAME_CHARS} printable '
                         'characters')
    return name


def check_bindable(address):
    """Raise ValueError if UDP ``address`` (a bacpypes3 ``Address``) cannot be bound now.

    bacpypes3 0.0.110 binds with ``SO_REUSEPORT`` and retries a failed bind for ever: a second
    application on the same ip:port would start silently and share the first one's unicast
    traffic, and an address that is not this host's would never come up. This probe binds
    without it, so either is refused at start.
    """
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind(address.addrTuple)
        except OSError as error:
            raise ValueError(f'address {address.addrTuple[0]}:{address.addrTuple[1]} cannot be '
                             f'bound: {error.strerror} (another BACnet application on this '
                             'port, or not an address of this host)') from None


class FacadeGateway(Application):
    """A BACnet device whose objects are a facade's (build it with :meth:`create`)."""

    @classmethod
    def create(cls, panel_ids, address, instance, name, closure_cov_percent=1.0,
               pressure_cov_pa=100.0, on_override=None, on_clear=None):
        """Create the application at ``address`` (from :func:`parse_address`).

        Must run inside the asyncio loop that will serve it. bacpypes3 binds in a task that
        retries a failed bind for ever: call :func:`check_bindable` first.
        """
        # str(address) drops the prefix length (a /24 would lose its broadcast listener)
        host, port = address.addrTuple
        app = cls.from_args(Namespace(
            name=name, instance=instance, address=f'{host}/{address.network.prefixlen}:{port}',
            network=0,
            vendoridentifier=VENDOR_IDENTIFIER, foreign=None, ttl=30, bbmd=None))
        app._configure(FacadeObjects(panel_ids, closure_cov_percent, pressure_cov_pa),
                       on_override or (lambda overrides: None), on_clear or (lambda ids: None))
        return app

    def _configure(self, table, on_override, on_clear):
        self.table = table
        for obj in table.objects:
            self.add_object(obj)
        self.device_object.modelName = 'flectofold BACnet gateway'
        self._on_override = on_override
        self._on_clear = on_clear
        self.slots = {panel_id: CommandSlots() for panel_id in table.commands.values()}
        self.overrides = dict.fromkeys(table.panels)
        """Each panel's override handed on [0, 1], None: automatic."""
        self.storm_latched = False
        self.refused = Counter()
        """Refused requests since start, by BACnet error code."""
        self.writes_accepted = 0
        self.slots_ended_by_storm = 0
        self.last_refusal = 'none'

    # -- the BMS's requests -----------------------------------------------------------------

    async def do_WritePropertyRequest(self, apdu):
        """Answer a WriteProperty: a closure command, checked; anything else refused."""
        try:
            panel_id, value, priority = self._check_write(apdu)
            priority, percent = check_command(value, priority, self.storm_latched)
        except Refused as refusal:
            self._refuse('WriteProperty', apdu, refusal)
        self.slots[panel_id].write(priority, percent)
        self.table.set_slot(panel_id, priority, percent)
        self.writes_accepted += 1
        LOGGER.info('%s: %s at priority %d from %s', apdu.objectIdentifier,
                    'relinquished' if percent is None else f'{percent:g} %', priority,
                    apdu.pduSource)
        self._hand_on(self.table.panels if panel_id == ALL_PANELS else [panel_id])
        await self.response(SimpleAckPDU(context=apdu))

    async def do_ReadPropertyRequest(self, apdu):
        """Answer a ReadProperty as bacpypes3 does; count and log its errors."""
        try:
            await super().do_ReadPropertyRequest(apdu)
        except ExecutionError as error:
            self._refuse('ReadProperty', apdu, Refused(error.errorClass, error.errorCode,
                                                       'no such object or property'))

    async def do_WritePropertyMultipleRequest(self, apdu):
        """Reject: commands come one WriteProperty at a time, through its checks."""
        self._reject_service('WritePropertyMultiple', apdu)

    async def do_DeviceCommunicationControlRequest(self, apdu):
        """Reject: the gateway has no DCC password to check."""
        self._reject_service('DeviceCommunicationControl', apdu)

    def _reject_service(self, service, apdu):
        self.refused['unrecognizedService'] += 1
        self.last_refusal = f'{service}: not executed by this device'
        LOGGER.warning('rejected %s from %s: not executed by this device', service,
                       getattr(apdu, 'pduSource', None))
        raise UnrecognizedService()

    def get_services_supported(self):
        """Return the :data:`SERVICES` bit string (the device object's property)."""
        supported = ServicesSupported([])
        for name in SERVICES:
            supported[getattr(supported, name)] = 1
        return supported

    def _check_write(self, apdu):
        obj = self.get_object_id(apdu.objectIdentifier)
        if obj is None:
            raise Refused('object', 'unknownObject', f'no object {apdu.objectIdentifier}')
        if obj.get_property_type(apdu.propertyIdentifier) is None:
            raise Refused('property', 'unknownProperty',
                          f'{apdu.objectIdentifier} has no {apdu.propertyIdentifier}')
        panel_id = self.table.commands.get(obj.objectIdentifier)
        if panel_id is None or apdu.propertyIdentifier != PropertyIdentifier.presentValue:
            raise Refused('property', 'writeAccessDenied',
                          f'{apdu.propertyIdentifier} of {apdu.objectIdentifier} is read-only: '
                          'only the present-value of a closure command is written')
        if apdu.propertyArrayIndex is not None:
            raise Refused('property', 'propertyIsNotAnArray', 'present-value is not an array')
        return panel_id, _decode(apdu.propertyValue), apdu.priority

    def _refuse(self, service, apdu, refusal):
        self.refused[refusal.error_code] += 1
        self.last_refusal = f'{service} {apdu.objectIdentifier}: {refusal.reason}'
        LOGGER.warning('refused %s from %s: %s %s', service, apdu.pduSource,
                       refusal.error_code, self.last_refusal)
        raise ExecutionError(refusal.error_class, refusal.error_code) from None

    # -- handing commands on ----------------------------------------------------------------

    def _hand_on(self, panel_ids):
        """Send each panel's effective override where it changed: an override, or a clear."""
        overrides, cleared = {}, []
        for panel_id in panel_ids:
            closure = effective_override(self.slots[panel_id], self.slots[ALL_PANELS])
            if closure == self.overrides[panel_id]:
                continue
            self.overrides[panel_id] = closure
            if closure is None:
                cleared.append(panel_id)
            else:
                overrides[panel_id] = closure
        if overrides:
            self._on_override(overrides)
        if cleared:
            self._on_clear(cleared)

    def refresh(self):
        """Hand every override in force on again (the coordinator's overrides expire)."""
        held = {p: c for p, c in self.overrides.items() if c is not None}
        if held:
            self._on_override(held)

    # -- the facade's state -----------------------------------------------------------------

    def set_storm(self, latched):
        """Take the storm latch; a trip ends every override slot, as the coordinator does."""
        latched = bool(latched)
        if latched and not self.storm_latched:
            ended = sum(slots.relinquish_overrides() for slots in self.slots.values())
            self.slots_ended_by_storm += ended
            for panel_id in self.slots:
                for priority in range(1, 9):
                    self.table.set_slot(panel_id, priority, None)
            # the coordinator ended its overrides itself: nothing to send, only to forget
            self.overrides = dict.fromkeys(self.overrides)
            if ended:
                LOGGER.warning('storm latch set: %d override slot(s) relinquished, the '
                               'panels return to automatic after the storm', ended)
        self.storm_latched = latched
        self.table.set_storm(latched)

    def set_automatic(self, panel_id, closure):
        """Take the coordinator's command for a panel [0, 1] as its relinquish default."""
        if panel_id in self.table.panels:
            self.table.set_automatic(panel_id, round(100.0 * closure, 6))

    def set_panel_state(self, panel_id, closure, pressure_pa, fault_word):
        """Take a panel's state: closure [0, 1], pressure [Pa] (NaN: none), fault word."""
        if panel_id in self.table.panels:
            self.table.set_panel_state(panel_id, 100.0 * closure, pressure_pa, fault_word)

    def mark_stale(self, panel_id):
        """Flag a panel's inputs unreliable (its state stopped arriving)."""
        self.table.mark_stale(panel_id)


def _decode(value):
    """Return a written ``Any`` as None (Null), a float (Real) or Refused (anything else)."""
    for kind, convert in ((Null, lambda v: None), (Real, float)):
        try:
            return convert(value.cast_out(kind))
        except Exception:  # noqa: B902 bacpypes3 raises several kinds on a tag mismatch
            continue
    raise Refused('property', 'invalidDataType', 'a closure command is a REAL in % or NULL')
