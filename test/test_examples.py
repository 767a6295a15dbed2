"""Every facade description in examples/ loads, with the panel count its first line states."""

from pathlib import Path
import re

import pytest

from flectofold_model.facade import load_facade
from flectofold_model.facade.schema import SURFACE_KEYS

EXAMPLES = Path(__file__).resolve().parents[1] / 'examples'
DESCRIPTIONS = sorted(EXAMPLES.glob('*.yaml'))


@pytest.mark.parametrize('path', DESCRIPTIONS, ids=[p.name for p in DESCRIPTIONS])
def test_an_example_loads_with_the_panels_it_states(path):
    stated = re.match(r'# panels: (\d+)\n', path.read_text())
    assert stated, f'{path.name}: the first line must be "# panels: N"'
    facade = load_facade(path)
    assert len(facade) == int(stated.group(1))
    assert not facade.excluded


def test_every_surface_type_and_both_panel_kinds_have_an_example():
    documents = [path.read_text() for path in DESCRIPTIONS]
    for kind in SURFACE_KEYS:
        assert any(f'type: {kind},' in text for text in documents), kind
    assert any('type: hexagon' in text for text in documents)


def test_the_obj_an_example_uses_is_in_examples():
    for path in DESCRIPTIONS:
        used = re.search(r'path: (\S+)\}', path.read_text())
        if used:
            assert (EXAMPLES / used.group(1)).is_file(), used.group(1)
