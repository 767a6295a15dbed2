"""Loading a facade warns once when its panels exceed the allowable strain at closure 1."""

import re
import warnings

import pytest

from flectofold_model.actuation.strain import StrainLimitWarning
from flectofold_model.facade.description import build_facade, load_facade

#: One row of 1 m panels; a 160 mm hinge keeps the 1.2 mm hinge lay-up under 0.7 % (it would
#: need about 140 mm), a 30 mm one does not.
FACADE = """
name: hinge-test
site: {{latitude_deg: 48.78, longitude_deg: 9.18, elevation_m: 245, utc_offset_h: 2}}
facade: {{azimuth_deg: 180}}
surface: {{type: saddle, width_m: 2.2, height_m: 1.1, curvature_u_per_m: -0.08,
          curvature_v_per_m: 0.08}}
grid: {{rows: 1, columns: 2, gap_m: 0.1, midrib_along: v}}
panel: {{fold_radius_m: 1.0, midrib_end_width_m: 0.04, hinge_width_m: {hinge}}}
"""


def strain_warnings(record):
    return [w for w in record if issubclass(w.category, StrainLimitWarning)]


@pytest.mark.parametrize('name', ['demonstrator_6x6', 'hexagon_6x6'])
def test_loading_an_embedded_facade_warns_once_naming_its_worst_panel(name):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter('always')
        facade = load_facade(name)
    found = strain_warnings(record)
    assert len(found) == 1
    message = str(found[0].message)
    assert f'facade {facade.name}' in message
    assert f'{len(facade)} of {len(facade)} panels exceed' in message
    worst = re.search(r'panel (r\d\dc\d\d), reaches (\d+\.\d+) % in its hinge', message)
    assert worst and worst.group(1) in facade.panel_ids and float(worst.group(2)) > 3.0
    assert found[0].filename == __file__  # points at the caller of load_facade


def test_a_facade_with_wide_enough_hinges_loads_without_a_warning(tmp_path):
    path = tmp_path / 'wide.yaml'
    path.write_text(FACADE.format(hinge=0.16))
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        assert len(load_facade(path)) == 2
    path.write_text(FACADE.format(hinge=0.03))
    with pytest.warns(StrainLimitWarning, match='2 of 2 panels exceed'):
        load_facade(path)


def test_building_from_text_does_not_check_strain():
    """The check belongs to load_facade, where users and nodes load a description."""
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        assert len(build_facade(FACADE.format(hinge=0.03))) == 2
