"""The facade's BACnet objects (bacpypes3 local objects) and their instance numbers.

Per panel, numbered by its place ``k`` (1-based) in the facade description:

* Analog Value ``k``, ``<id> closure command`` [%], commandable (16-slot priority array; the
  relinquish default follows the coordinator's own command, so that with every slot NULL the
  present value is what the schedule, or the storm, commands);
* Analog Input ``k``, ``<id> closure`` [%], the closure from the measured pressure;
* Analog Input ``1000 + k``, ``<id> cushion pressure`` [Pa], absolute;
* Multi-state Input ``k``, ``<id> fault``: state ``1 + index`` of the fault word in
  :data:`flectofold_ros.wire.contract.FAULTS` (1: none); event state offnormal and status
  flag in-alarm while a fault is latched.

Facade-wide: Analog Value 0, ``facade closure command`` [%] (every panel, below a panel's own
command), and Binary Input 0, ``storm latch`` (active while latched; event state offnormal
and status flag in-alarm with it). The inputs serve COV (increments for the analog ones).
Which properties each has and what the gateway does with writes: ``msg_docs/bacnet_gateway.md``.
"""

from bacpypes3.basetypes import (EngineeringUnits, EventState, PriorityValue, Reliability,
                                 StatusFlags)
from bacpypes3.local.analog import AnalogInputObject, AnalogValueObjectCmd
from bacpypes3.local.binary import BinaryInputObject
from bacpypes3.local.cov import GenericCriteria
from bacpypes3.local.multistate import MultiStateInputObject as _MultiStateInputObject
from bacpypes3.primitivedata import CharacterString

from flectofold_ros.wire import contract

#: Instance of the facade-wide objects (closure command, storm latch).
FACADE_INSTANCE = 0
#: Pressure inputs are numbered from here (1000 + k).
PRESSURE_INSTANCE_BASE = 1000
#: What the facade-wide command's panel id is (the coordinator's word for every panel).
ALL_PANELS = contract.ALL_PANELS
MAX_PANELS = PRESSURE_INSTANCE_BASE - 1


class MultiStateInputObject(_MultiStateInputObject):
    """bacpypes3's Multi-state Input with COV on every change of state.

    bacpypes3 0.0.110 gives multi-state objects the COV-increment criteria, which read a
    ``covIncrement`` they do not have (a SubscribeCOV then fails with operational-problem);
    ASHRAE 135 Table 13-1 reports them on any change of present value or status flags.
    """

    _cov_criteria = GenericCriteria


def _flags(in_alarm=False, fault=False):
    return StatusFlags([int(in_alarm), int(fault), 0, 0])


def closure_command(instance, name, cov_increment_percent):
    """Return a commandable Analog Value [%]: every slot NULL, relinquish default 0."""
    return AnalogValueObjectCmd(
        objectIdentifier=('analogValue', instance), objectName=name,
        presentValue=0.0, relinquishDefault=0.0, units=EngineeringUnits('percent'),
        statusFlags=_flags(), eventState=EventState('normal'), outOfService=False,
        covIncrement=cov_increment_percent, minPresValue=0.0, maxPresValue=100.0,
        description=CharacterString('closure 0 open .. 100 closed; priorities 1-8 override, '
                                    '9-16 refused, relinquish: automatic'))


def analog_input(instance, name, units, cov_increment):
    """Return an Analog Input with a COV increment, unreliable until its first value."""
    return AnalogInputObject(
        objectIdentifier=('analogInput', instance), objectName=name, presentValue=0.0,
        units=EngineeringUnits(units), statusFlags=_flags(fault=True),
        reliability=Reliability('communicationFailure'), eventState=EventState('normal'),
        outOfService=False, covIncrement=cov_increment)


def fault_input(instance, name):
    """Return a Multi-state Input of the fault words (state 1: none)."""
    return MultiStateInputObject(
        objectIdentifier=('multiStateInput', instance), objectName=name, presentValue=1,
        numberOfStates=len(contract.FAULTS), stateText=list(contract.FAULTS),
        statusFlags=_flags(fault=True), reliability=Reliability('communicationFailure'),
        eventState=EventState('normal'), outOfService=False)


def storm_input(name='storm latch'):
    """Return the storm latch as a Binary Input (inactive until told)."""
    return BinaryInputObject(
        objectIdentifier=('binaryInput', FACADE_INSTANCE), objectName=name,
        presentValue='inactive', polarity='normal', statusFlags=_flags(),
        eventState=EventState('normal'), outOfService=False,
        activeText='storm: panels at the storm position', inactiveText='no storm')


class PanelObjects:
    """One panel's four objects."""

    def __init__(self, panel_id, number, closure_cov_percent, pressure_cov_pa):
        self.panel_id = panel_id
        self.command = closure_command(number, f'{panel_id} closure command', closure_cov_percent)
        self.closure = analog_input(number, f'{panel_id} closure', 'percent', closure_cov_percent)
        self.pressure = analog_input(PRESSURE_INSTANCE_BASE + number,
                                     f'{panel_id} cushion pressure', 'pascals', pressure_cov_pa)
        self.fault = fault_input(number, f'{panel_id} fault')

    @property
    def objects(self):
        return [self.command, self.closure, self.pressure, self.fault]


class FacadeObjects:
    """The object table of a facade: per-panel objects, the facade command and storm latch."""

    def __init__(self, panel_ids, closure_cov_percent=1.0, pressure_cov_pa=100.0):
        if not 1 <= len(panel_ids) <= MAX_PANELS:
            raise ValueError(f'a facade of {len(panel_ids)} panels: the object table numbers '
                             f'1..{MAX_PANELS}')
        self.panels = {panel_id: PanelObjects(panel_id, number + 1, closure_cov_percent,
                                              pressure_cov_pa)
                       for number, panel_id in enumerate(panel_ids)}
        self.facade_command = closure_command(FACADE_INSTANCE, 'facade closure command',
                                              closure_cov_percent)
        self.storm = storm_input()
        #: objectIdentifier of each commandable object -> its panel id (or ALL_PANELS).
        self.commands = {self.facade_command.objectIdentifier: ALL_PANELS}
        self.commands.update({p.command.objectIdentifier: panel_id
                              for panel_id, p in self.panels.items()})

    @property
    def objects(self):
        """Every object of the table (the device object is the application's)."""
        return [self.facade_command, self.storm,
                *(o for panel in self.panels.values() for o in panel.objects)]

    def command_object(self, panel_id):
        """Return the closure command object of a panel id or of ALL_PANELS."""
        if panel_id == ALL_PANELS:
            return self.facade_command
        return self.panels[panel_id].command

    # -- updates from the facade ------------------------------------------------------------

    def set_slot(self, panel_id, priority, percent):
        """Write slot ``priority`` of a command object: ``percent`` or None (NULL)."""
        value = PriorityValue(null=()) if percent is None else PriorityValue(real=percent)
        self.command_object(panel_id).priorityArray[priority - 1] = value

    def set_automatic(self, panel_id, percent):
        """Set a panel's relinquish default: the coordinator's command [%]."""
        command = self.panels[panel_id].command
        if command.relinquishDefault != percent:
            command.relinquishDefault = percent
            command.recalculating()

    def set_panel_state(self, panel_id, closure_percent, pressure_pa, fault_word):
        """Set a panel's inputs from its state (NaN pressure: no reading, flagged)."""
        panel = self.panels[panel_id]
        _set_input(panel.closure, closure_percent)
        _set_input(panel.pressure, pressure_pa)
        if fault_word not in contract.FAULTS:
            _mark_unreliable(panel.fault, 'unreliableOther')
            return
        faulted = fault_word != contract.NO_FAULT
        _mark_reliable(panel.fault, in_alarm=faulted)
        event_state = EventState('offnormal' if faulted else 'normal')
        if panel.fault.eventState != event_state:
            panel.fault.eventState = event_state
        state = contract.FAULTS.index(fault_word) + 1
        if panel.fault.presentValue != state:
            panel.fault.presentValue = state

    def mark_stale(self, panel_id):
        """Flag a panel's inputs unreliable: its state stopped arriving."""
        panel = self.panels[panel_id]
        for obj in (panel.closure, panel.pressure, panel.fault):
            _mark_unreliable(obj, 'communicationFailure')

    def set_storm(self, latched):
        """Set the storm latch object: present value, event state, in-alarm flag."""
        value = 'active' if latched else 'inactive'
        if self.storm.presentValue != value:
            self.storm.eventState = EventState('offnormal' if latched else 'normal')
            self.storm.statusFlags = _flags(in_alarm=latched)
            self.storm.presentValue = value


def _set_input(obj, value):
    if value != value:  # NaN: no reading
        _mark_unreliable(obj, 'noSensor')
        return
    _mark_reliable(obj)
    if obj.presentValue != value:
        obj.presentValue = value


def _mark_reliable(obj, in_alarm=False):
    if obj.reliability != Reliability('noFaultDetected'):
        obj.reliability = Reliability('noFaultDetected')
    flags = _flags(in_alarm=in_alarm)
    if list(obj.statusFlags) != list(flags):
        obj.statusFlags = flags


def _mark_unreliable(obj, reason):
    if obj.reliability != Reliability(reason):
        obj.reliability = Reliability(reason)
        obj.statusFlags = _flags(fault=True)
