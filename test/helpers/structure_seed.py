"""Put a facade's structural cushion map into a cache quickly, for the processes of a test.

The map a facade reads is its median panel's, traced on ``cushion_tables.MAP_MESH``: about
15 s of CPU. A test seeds the cache entry of that design with the tables of a quick path
instead (the same panel with a soft hinge on the coarsest mesh, about 3 s), so what it checks
is that the processes read the cache, not the mechanics (``test/model/structure`` checks
those).
"""

from dataclasses import replace
from unittest import mock

from flectofold_model.actuation import actuated_like
from flectofold_model.facade.footprint import representative_index
from flectofold_model.structure import cushion_tables
from flectofold_model.structure.facade_map import median_structural_map
from flectofold_model.structure.panel import PanelMesh, structural_path

QUICK_MESH = PanelMesh(20, 2, 1, 2)


def quick_median_path(facade):
    """Trace the quick path of ``facade``'s median panel: a soft hinge on the coarsest mesh."""
    median = actuated_like(facade.panels[representative_index(facade)])
    return structural_path(replace(median, hinge=replace(median.hinge, youngs_modulus_pa=5e8)),
                           QUICK_MESH)


def seed_structural_map(facade, cache_directory, path):
    """Write ``facade``'s structural map, of the quick ``path``, into ``cache_directory``.

    Return the map.
    """
    with mock.patch.dict('os.environ', {cushion_tables.CACHE_ENVIRONMENT: str(cache_directory)}), \
            mock.patch.object(cushion_tables, 'structural_path', lambda *_, **__: path):
        return median_structural_map(facade)
