"""What the facade's markers show, kept apart from ROS: folded triangles, colours, changes.

:class:`FacadeMarkers` takes panel states (:mod:`flectofold_ros.wire.panel_states` tables), keeps
each panel's triangles in the site ENU frame (from the one folded-facade mesher,
:class:`~flectofold_model.facade.folded_mesh.FacadeMesher`) and says which panels changed
since it was last asked. The node (:mod:`flectofold_ros.nodes.facade_markers`) turns them
into ``visualization_msgs/Marker`` messages.
"""

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import FloatArray, IntArray
from flectofold_model.facade.description import Facade
from flectofold_model.facade.folded_mesh import FacadeMesher
from flectofold_ros.wire import colours, panel_states
from flectofold_ros.wire.colours import RgbaArray
from flectofold_ros.wire.panel_states import Table

#: The arrow toward the sun starts at the facade's centre and is this long [m].
SUN_ARROW_M = 3.0
#: The facade's surface is drawn this far behind the flat panels [m].
SURFACE_DEPTH_M = 0.05


class FacadeMarkers:
    """The markers' content for ``facade``: every panel's triangles and colour.

    ``min_change_rad``: a panel whose fold angle changed less than this since its triangles
    were last handed out is not re-meshed (its colour may still change).
    """

    SURFACE_RGBA = colours.SURFACE_RGBA
    SUN_RGBA = colours.SUN_RGBA

    def __init__(self, facade: Facade, min_change_rad: float = 1e-3) -> None:
        self.facade = facade
        self.mesher = FacadeMesher(facade)
        count = len(self.mesher)
        self._lookup = panel_states.index_lookup(facade.panel_ids)
        self.min_change_rad = float(min_change_rad)
        self.fold_angle_rad = self.mesher.angle_limits_rad[0].copy()
        self.closure = np.zeros(count)
        self.fault = np.zeros(count, dtype=np.int16)
        self.seen = np.zeros(count, dtype=bool)
        self._faces = np.asarray(self.mesher.faces, dtype=np.intp)
        self._vertices = np.zeros((count, self.mesher.topology.vertex_count, 3))
        self._meshed_rad = np.full(count, np.nan)
        self._shown_rgba = np.zeros((count, 4), dtype=np.uint8)
        self._remesh(np.arange(count))

    def __len__(self) -> int:
        return len(self.mesher)

    def take(self, table: Table) -> int:
        """Take a panel_states table; return how many of its points were this facade's."""
        index = panel_states.indices(table, self._lookup)
        angle = table['fold_angle_rad'].astype(float)
        closure = table['closure'].astype(float)
        valid = (index >= 0) & np.isfinite(angle) & np.isfinite(closure)
        index = index[valid]
        self.fold_angle_rad[index] = angle[valid]
        self.closure[index] = closure[valid]
        self.fault[index] = table['fault'][valid]
        self.seen[index] = True
        return len(index)

    def changed(self, everything: bool = False) -> IntArray:
        """Return the panels whose marker changed since the last call (all: ``everything``).

        Re-meshes the panels that moved by more than ``min_change_rad``.
        """
        moved = ~(np.abs(self.fold_angle_rad - self._meshed_rad) <= self.min_change_rad)
        self._remesh(np.flatnonzero(moved))
        rgba = self.colours()
        recoloured = np.any(rgba != self._shown_rgba, axis=1)
        self._shown_rgba = rgba
        return np.arange(len(self)) if everything else np.flatnonzero(moved | recoloured)

    def _remesh(self, panels: IntArray) -> None:
        if len(panels):
            angle = self.fold_angle_rad[panels]
            batch = self.mesher.batch(panels)
            vertices, _ = self.mesher.world_mesh(panels, self.mesher.shapes(panels, angle, batch),
                                                 batch, dtype=np.float64)
            self._vertices[panels] = vertices
            self._meshed_rad[panels] = angle

    def colours(self) -> RgbaArray:
        """(N, 4) uint8 RGBA of every panel now (:func:`.colours.panel_colours`)."""
        return colours.panel_colours(self.closure, self.seen, self.fault)

    def colour(self, index: int) -> tuple[int, ...]:
        """RGBA of panel ``index`` as last handed out by :meth:`changed`."""
        return tuple(int(c) for c in self._shown_rgba[index])

    def triangles(self, index: int) -> FloatArray:
        """(3 T, 3) corners of panel ``index``'s triangles in ENU [m], three per triangle."""
        return self._vertices[index][self._faces].reshape(-1, 3)

    def surface_triangles(self) -> FloatArray:
        """(3 T, 3) corners of the facade's surface (each flat panel outline, fanned) [m]."""
        corners = self.mesher.outline_enu(SURFACE_DEPTH_M)
        count = corners.shape[1]
        fan = np.array([(0, k, k + 1) for k in range(1, count - 1)])
        return corners[:, fan].reshape(-1, 3)

    def sun_arrow(self, toward_sun_enu: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Tail and head [m] of the arrow from the facade's centre toward the sun."""
        tail = self.mesher.positions_enu.mean(axis=0)
        return tail, tail + SUN_ARROW_M * np.asarray(toward_sun_enu, dtype=float)
