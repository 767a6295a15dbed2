"""Faults injected into simulated panels from outside: the requests and what they change.

A request names a fault kind, the panels and the fault's figures (``msg_docs/fault_injection.md``
has the topic, every kind and the loop's expected reaction). :func:`parse_request` checks one
against the facade; a :class:`FaultInjector` keeps, per panel and kind, what is injected into
one simulated plant and installs it there. Pure (no rclpy): the panel process takes requests
from ``/facade/inject_fault`` with it, and the fault script checks its entries with it.
"""

from dataclasses import dataclass, field
import math
from numbers import Real
from typing import Iterable, Protocol, Sequence

import numpy as np

from flectofold_model._validate import BoolArray, IntArray
from flectofold_ros.wire import contract


class FaultRequestError(ValueError):
    """A fault request refused; the message says why."""


class Plant(Protocol):
    """What a simulated plant takes faults with, each for the panels of a boolean mask (N,)."""

    def clear_faults(self) -> None: ...

    def inject_leak(self, panels: BoolArray, conductance_m3_s_pa: float) -> None: ...

    def inject_sensor_noise(self, panels: BoolArray, noise_pa: float) -> None: ...

    def inject_sensor_stuck(self, panels: BoolArray) -> None: ...

    def inject_sensor_dropout(self, panels: BoolArray) -> None: ...

    def inject_supply_loss(self, panels: BoolArray) -> None: ...

    def inject_fill_valve_stuck_open(self, panels: BoolArray) -> None: ...


@dataclass(frozen=True)
class Figure:
    """A figure a fault takes: name (with its unit), bounds ``(low, high]``, unit text."""

    name: str
    low: float
    high: float
    unit: str


#: Longest a timed fault lasts [s of ROS time]: a week.
MAX_DURATION_S = 7 * 86400.0
DURATION = Figure('duration_s', 0.0, MAX_DURATION_S, 's')
#: Up to 10 dm^3/(s*bar), four times the demonstrator's vent valve [m^3/(s*Pa)].
LEAK = Figure('conductance_m3_s_pa', 0.0, 1e-7, 'm^3/(s*Pa)')
#: Up to a quarter of the sensor's 20 kPa range [Pa].
NOISE = Figure('noise_std_pa', 0.0, 5e3, 'Pa')


@dataclass(frozen=True)
class Kind:
    """A fault kind: the figures it needs, those it may take, the kinds it clears."""

    required: tuple = ()
    optional: tuple = (DURATION,)
    clears: tuple = ()

    def figures(self) -> dict[str, Figure]:
        return {figure.name: figure for figure in (*self.required, *self.optional)}


#: The faults a plant takes, by the word a request names them with.
INJECTED = {
    contract.INJECT_SENSOR_STUCK: Kind(),
    contract.INJECT_SENSOR_DROPOUT: Kind(),
    contract.INJECT_SENSOR_NOISE: Kind(required=(NOISE,)),
    contract.INJECT_LEAK: Kind(required=(LEAK,)),
    contract.INJECT_SUPPLY_LOSS: Kind(),
    contract.INJECT_FILL_VALVE_STUCK_OPEN: Kind(),
}
#: Every kind a request may name: the faults, and the two that take them away again.
KINDS = {
    **INJECTED,
    contract.INJECT_SUPPLY_RESTORE: Kind(optional=(), clears=(contract.INJECT_SUPPLY_LOSS,)),
    contract.INJECT_RESTORE: Kind(optional=(), clears=tuple(INJECTED)),
}
#: Most figures a request carries, and the longest text of one [characters].
MAX_VALUES = 8
MAX_VALUE_CHARACTERS = 64
_ID_CHARACTERS = len('r00c00,')


@dataclass(frozen=True)
class FaultRequest:
    """A checked request: kind, panel ids (or ``('*',)``) and figures ``{name: value}``."""

    kind: str
    panels: tuple
    values: dict = field(default_factory=dict)

    @property
    def every_panel(self) -> bool:
        return self.panels == (contract.ALL_PANELS,)

    @property
    def duration_s(self) -> float:
        """How long the fault lasts [s of ROS time]; inf: until restored."""
        return self.values.get(DURATION.name, math.inf)

    def describe(self) -> str:
        """One line: ``leak (conductance_m3_s_pa=2e-08) on r00c01, r00c02``."""
        figures = ', '.join(f'{name}={value:g}' for name, value in self.values.items())
        panels = 'every panel' if self.every_panel else _span(self.panels)
        return f'{self.kind}{f" ({figures})" if figures else ""} on {panels}'


def parse_request(kind: object, panels: object, values: Iterable[tuple[str, object]],
                  facade_ids: Sequence[str]) -> FaultRequest:
    """Check a request against the facade's panel ids; return the :class:`FaultRequest`.

    ``panels``: ``'*'``, comma-separated ids or a list of ids; ``values``: ``(name, value)``
    pairs, a value a number or its text. Raises :class:`FaultRequestError` naming the reason.
    """
    if not isinstance(kind, str) or kind not in KINDS:
        raise FaultRequestError(f'unknown fault kind {_quote(kind)}: one of '
                                f'{", ".join(KINDS)}')
    return FaultRequest(kind, check_panels(panels, facade_ids), check_values(kind, values))


def check_panels(panels: object, facade_ids: Sequence[str]) -> tuple[str, ...]:
    """Return the panel ids of a request as a tuple, or ``('*',)`` for every panel."""
    if panels == contract.ALL_PANELS:
        return (contract.ALL_PANELS,)
    if isinstance(panels, str):
        if len(panels) > _ID_CHARACTERS * len(facade_ids):
            raise FaultRequestError(f'the panel list is longer than the {len(facade_ids)} '
                                    f'panels of the facade')
        panels = [panel.strip() for panel in panels.split(',')]
    if not isinstance(panels, (list, tuple)) or not panels:
        raise FaultRequestError(f"panels must be '*' or a list of panel ids, got "
                                f'{_quote(panels)}')
    if len(panels) > len(facade_ids):
        raise FaultRequestError(f'{len(panels)} panels named; the facade has '
                                f'{len(facade_ids)}')
    known = set(facade_ids)
    unknown = [panel for panel in panels if not (isinstance(panel, str) and panel in known)]
    if unknown:
        raise FaultRequestError(f'unknown panel(s) {", ".join(map(_quote, unknown[:5]))}: the '
                                f'facade has {facade_ids[0]} .. {facade_ids[-1]}')
    if len(set(panels)) != len(panels):
        raise FaultRequestError('a panel is named twice')
    return tuple(panels)


def check_values(kind: str, values: Iterable[tuple[str, object]]) -> dict[str, float]:
    """Return a kind's figures ``{name: float}`` from ``(name, value)`` pairs, checked."""
    values = list(values)
    if len(values) > MAX_VALUES:
        raise FaultRequestError(f'{len(values)} values; a fault takes at most {MAX_VALUES}')
    figures = KINDS[kind].figures()
    checked: dict[str, float] = {}
    for name, value in values:
        figure = figures.get(name)
        if figure is None:
            known = ', '.join(figures) or 'none'
            raise FaultRequestError(f'{kind} takes no value {_quote(name)} (it takes: {known})')
        if name in checked:
            raise FaultRequestError(f'{name} is given twice')
        checked[name] = _figure(figure, value)
    missing = [figure.name for figure in KINDS[kind].required if figure.name not in checked]
    if missing:
        raise FaultRequestError(f'{kind} needs {", ".join(missing)}')
    return checked


def _figure(figure: Figure, value: object) -> float:
    if isinstance(value, str):
        text = value.strip()
        if len(text) > MAX_VALUE_CHARACTERS:
            raise FaultRequestError(f'{figure.name} is no number: {_quote(value)}')
        try:
            value = float(text)
        except ValueError:
            raise FaultRequestError(f'{figure.name} is no number: {_quote(value)}') from None
    if isinstance(value, bool) or not isinstance(value, Real):
        raise FaultRequestError(f'{figure.name} is no number: {_quote(value)}')
    value = float(value)
    if not (math.isfinite(value) and figure.low < value <= figure.high):
        raise FaultRequestError(f'{figure.name} must lie in ({figure.low:g}, {figure.high:g}] '
                                f'{figure.unit}, got {value:g}')
    return value


def request_fields(request: FaultRequest) -> tuple[str, str, list[tuple[str, str]]]:
    """``(name, hardware_id, [(key, value text)])`` of the message that carries ``request``."""
    values = [(name, repr(value)) for name, value in request.values.items()]
    return request.kind, ','.join(request.panels), values


class FaultInjector:
    """What is injected, per panel and kind, into one simulated plant of ``panel_ids``.

    A panel holds at most one fault of each kind: injecting a kind again replaces its figure
    and its end. Every change clears the plant's faults and installs the whole book again,
    which is how one panel's faults are taken away while the others' stay.
    """

    def __init__(self, plant: Plant, panel_ids: Iterable[str]) -> None:
        self.plant = plant
        self.panel_ids = list(panel_ids)
        self._position = {panel_id: index for index, panel_id in enumerate(self.panel_ids)}
        count = len(self.panel_ids)
        # per kind: when it ends [s of ROS time] (NaN: not injected; inf: until restored)
        self._until = {kind: np.full(count, np.nan) for kind in INJECTED}
        self._figure = {kind: np.zeros(count) for kind in INJECTED}
        self._text = ['none'] * count

    def indices(self, request: FaultRequest) -> IntArray:
        """Return the indices of the panels of ``request`` this plant holds (maybe none)."""
        if request.every_panel:
            return np.arange(len(self.panel_ids))
        return np.array([self._position[p] for p in request.panels if p in self._position],
                        dtype=np.int64)

    def apply(self, request: FaultRequest, now_s: float) -> IntArray:
        """Inject or clear ``request`` on this plant's panels of it; return their indices.

        ``now_s``: the ROS time [s] a timed fault counts from.
        """
        indices = self.indices(request)
        if not indices.size:
            return indices
        if request.duration_s != math.inf and not now_s > 0.0:
            raise FaultRequestError('a timed fault needs the clock, and none has come yet')
        kind = KINDS[request.kind]
        for cleared in kind.clears:
            self._until[cleared][indices] = np.nan
        if request.kind in INJECTED:
            figure = next(iter(set(request.values) - {DURATION.name}), None)
            self._until[request.kind][indices] = now_s + request.duration_s
            self._figure[request.kind][indices] = request.values.get(figure, 0.0)
        self._install(indices)
        return indices

    def expire(self, now_s: float) -> list[tuple[str, str]]:
        """End the timed faults due by ``now_s`` [s]; return ``[(panel id, kind)]`` ended."""
        ended: list[tuple[str, str]] = []
        for kind, until in self._until.items():
            due = np.flatnonzero(until <= now_s)
            if due.size:
                until[due] = np.nan
                ended += [(self.panel_ids[i], kind) for i in due.tolist()]
        if ended:
            self._install(np.array(sorted({self._position[p] for p, _ in ended})))
        return ended

    def injected(self, index: int) -> str:
        """Return what panel ``index`` has injected: ``'leak(2e-08), sensor_stuck'``, ``none``."""
        return self._text[index]

    def injected_kinds(self, index: int) -> list[str]:
        """Return the kinds injected into panel ``index`` now."""
        return [kind for kind, until in self._until.items() if not math.isnan(until[index])]

    def _install(self, changed: IntArray) -> None:
        plant = self.plant
        plant.clear_faults()
        for kind, until in self._until.items():
            mask = ~np.isnan(until)
            if not mask.any():
                continue
            if kind == contract.INJECT_LEAK:
                for value in np.unique(self._figure[kind][mask]):
                    plant.inject_leak(mask & (self._figure[kind] == value), float(value))
            elif kind == contract.INJECT_SENSOR_NOISE:
                for value in np.unique(self._figure[kind][mask]):
                    plant.inject_sensor_noise(mask & (self._figure[kind] == value),
                                              float(value))
            else:
                getattr(plant, _PLANT_METHOD[kind])(mask)
        for index in changed.tolist():
            kinds = self.injected_kinds(index)
            self._text[index] = ', '.join(
                f'{kind}({self._figure[kind][index]:g})' if KINDS[kind].required else kind
                for kind in kinds) or 'none'


_PLANT_METHOD = {
    contract.INJECT_SENSOR_STUCK: 'inject_sensor_stuck',
    contract.INJECT_SENSOR_DROPOUT: 'inject_sensor_dropout',
    contract.INJECT_SUPPLY_LOSS: 'inject_supply_loss',
    contract.INJECT_FILL_VALVE_STUCK_OPEN: 'inject_fill_valve_stuck_open',
}


def _span(ids: Sequence[str]) -> str:
    return ', '.join(ids) if len(ids) <= 6 else f'{ids[0]} ... {ids[-1]} ({len(ids)} panels)'


def _quote(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else f'{text[:37]}...'
