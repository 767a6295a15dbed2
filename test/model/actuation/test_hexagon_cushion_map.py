"""The tabulated static map of hexagonal panels: one table per distinct panel, as for quads."""

import dataclasses

import numpy as np
import pytest

from flectofold_model.actuation import (CushionMap, HEXAGON_ACTUATED, HexagonActuationModel,
                                        RoundCushion)
from flectofold_model.actuation import hexagon_statics

OTHER = dataclasses.replace(HEXAGON_ACTUATED, cushion=RoundCushion(0.27, 0.005))


@pytest.fixture(scope='module')
def model():
    return HexagonActuationModel([HEXAGON_ACTUATED, OTHER])


@pytest.fixture(scope='module')
def table(model):
    return CushionMap(model, samples=257)


def test_a_mixed_list_of_identical_panels_is_tabulated_once_per_distinct_panel(monkeypatch,
                                                                               table):
    tabulated = []
    original = hexagon_statics.HexagonActuationModel.shape_table

    def counting(self, closures):
        tabulated.append(len(self))
        return original(self, closures)

    monkeypatch.setattr(hexagon_statics.HexagonActuationModel, 'shape_table', counting)
    panels = [HEXAGON_ACTUATED, OTHER, HEXAGON_ACTUATED, HEXAGON_ACTUATED, OTHER]
    mixed = CushionMap(HexagonActuationModel(panels), samples=257)
    assert tabulated == [2]
    assert mixed.distinct_count == 2
    np.testing.assert_array_equal(mixed.row, [0, 1, 0, 0, 1])
    expected = table.pressure_pa[[0, 1, 0, 0, 1]]
    np.testing.assert_allclose(mixed.pressure_pa, expected, rtol=1e-12)
    np.testing.assert_allclose(mixed.volume_m3, table.volume_m3[[0, 1, 0, 0, 1]], rtol=1e-12)


def test_tables_are_monotone_from_zero_to_the_closed_pressure(model, table):
    assert np.all(np.diff(table.pressure_pa, axis=1) > 0)
    np.testing.assert_allclose(table.pressure_pa[:, 0], 0.0, atol=1e-5)
    np.testing.assert_allclose(table.pressure_pa[:, -1], model.closed_pressure_pa, rtol=1e-9)
    assert np.all(np.diff(table.volume_m3, axis=1) > 0)
    assert np.all(table.compliance_m3_per_pa > 0)
    np.testing.assert_allclose(table.fold_angle_rad[:, -1], model.fold.closed_fold_angle_rad)


def test_cushion_map_interpolates_the_model(model, table):
    pressure = np.array([3000.0, 6000.0])
    volume, compliance = table(pressure)
    rise = model.shape_from_pressure(pressure)
    np.testing.assert_allclose(volume, model.cushion_volume_m3(rise), rtol=1e-4)
    np.testing.assert_allclose(table.closure(pressure), model.closure_from_pressure(pressure),
                               atol=1e-4)
    step = 1.0
    slope = (model.cushion_volume_m3(model.shape_from_pressure(pressure + step))
             - model.cushion_volume_m3(model.shape_from_pressure(pressure - step))) / (2 * step)
    np.testing.assert_allclose(compliance, slope, rtol=1e-2)
    _, outside = table(np.array([-10.0, 1e6]))
    np.testing.assert_array_equal(outside, 0.0)
    closures = np.array([0.3, 0.85])
    np.testing.assert_allclose(table.pressure_for_closure(closures),
                               model.pressure_from_closure(closures), rtol=1e-3)
    np.testing.assert_allclose(table.closure(table.pressure_for_closure(closures)), closures,
                               atol=1e-9)


def test_a_non_monotone_map_is_refused(monkeypatch, model):
    """A panel that would snap through cannot be tabulated (CushionMap checks the tables)."""
    original = hexagon_statics.HexagonActuationModel.pressure

    def snapping(self, rise, index):
        pressure = original(self, rise, index)
        middle = (self.fold.open_shape[index] + self.fold.closed_shape[index]) / 2
        return np.where(rise > middle, 0.5 * pressure, pressure)

    monkeypatch.setattr(hexagon_statics.HexagonActuationModel, 'pressure', snapping)
    with pytest.raises(ValueError, match='not monotone'):
        CushionMap(model, samples=33)
