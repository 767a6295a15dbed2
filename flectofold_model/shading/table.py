"""Precomputed shading of one panel type, for choosing closures every control period.

Ray casting (:mod:`.ray_casting`) costs a fraction of a millisecond per panel and sun
(msg_docs/hexagon_shading.md, section "CPU cost"); a coordinator of thousands of panels
cannot spend that for every candidate closure every period. A :class:`ShadingTable` casts
once, for one panel geometry, over a grid of sun directions and candidate closures, and then
answers by bilinear interpolation, vectorised over any number of panels that share the
geometry.

The panel is a quad panel (:class:`~flectofold_model.kinematics.panel.PanelGeometry`) or a
hexagonal one (:class:`~flectofold_model.kinematics.hexagon_panel.HexagonPanel`); each is cast with
its kind's mesh and tiling (:mod:`.ray_casting`).

Sun directions are tabulated by their two profile angles in the panel frame,
``alpha = atan2(s_x, s_z)`` (along x: the mid-rib of a quad panel) and
``beta = atan2(s_y, s_z)`` (along y),
each in ``[-max_profile_deg, max_profile_deg]``; a sun beyond the grid is clamped to its edge,
and one behind the facade (``s_z <= 0``) blocks nothing and is not sunlit. The accuracy of the
interpolation against direct ray casting is measured in the tests and printed by
``bench/bench_schedule.py``.
"""

from typing import cast

import numpy as np
import numpy.typing as npt

from flectofold_model._validate import BoolArray, FloatArray, IntArray
from flectofold_model.kinematics.hexagon_panel import HexagonPanel
from flectofold_model.kinematics.kinds import batch_of, fold_model_of, Panel
from flectofold_model.kinematics.panel import PanelGeometry
from flectofold_model.shading.ray_casting import (blocked_fraction, choose_candidate,
                                                  SUNLIT_MIN_SZ, view_fraction)


class ShadingTable:
    """Blocked fractions of one panel geometry over sun directions and candidate closures.

    ``panel`` is a :class:`PanelGeometry` or a :class:`HexagonPanel`; ``samples`` is the
    resolution of :func:`.ray_casting.blocked_fraction` (72 scan lines for the default 24;
    the nodes' accuracy: msg_docs/scheduling.md, section "Accuracy of the blocked fraction").
    """

    def __init__(self, panel: Panel, closures: npt.ArrayLike = np.linspace(0.0, 1.0, 11),
                 step_deg: float = 5.0, max_profile_deg: float = 85.0,
                 samples: int = 24) -> None:
        if not isinstance(panel, (PanelGeometry, HexagonPanel)):
            raise TypeError(f'panel must be a PanelGeometry or a HexagonPanel, got '
                            f'{type(panel).__name__}')
        closures = np.asarray(closures, dtype=float)
        if closures.ndim != 1 or closures.size < 2 or np.any(np.diff(closures) <= 0):
            raise ValueError('closures must be an increasing 1-D array of at least 2 values')
        if not 0 < step_deg <= max_profile_deg < 90:
            raise ValueError(f'need 0 < step_deg <= max_profile_deg < 90, got {step_deg:g} '
                             f'and {max_profile_deg:g}')
        self.panel = panel
        self.closures = closures
        count = int(round(2 * max_profile_deg / step_deg)) + 1
        self.profile_rad = np.radians(np.linspace(-max_profile_deg, max_profile_deg, count))
        one = batch_of([panel])
        fold = fold_model_of(one)
        shape = np.array([fold.state_from_closure(c).shape_parameter[0] for c in closures])
        alpha, beta = np.meshgrid(self.profile_rad, self.profile_rad, indexing='ij')
        sun = np.stack([np.tan(alpha), np.tan(beta), np.ones_like(alpha)], axis=-1)
        sun = (sun / np.linalg.norm(sun, axis=-1, keepdims=True)).reshape(-1, 3)
        cases = one.take(np.zeros(closures.size * sun.shape[0], dtype=np.intp))
        states = np.repeat(shape, sun.shape[0])
        suns = np.tile(sun, (closures.size, 1))
        blocked = blocked_fraction(cases, states, suns, samples=samples).blocked_fraction
        self.blocked = blocked.reshape(closures.size, count, count)
        """(C, A, B) blocked fraction per closure and profile angles."""
        self.view = view_fraction(one.take(np.zeros(closures.size, dtype=np.intp)), shape,
                                  samples=samples)
        """(C,) view fraction per closure."""

    def blocked_fractions(self, sun_panel: npt.ArrayLike) -> FloatArray:
        """(N, C) blocked fractions for sun directions (N, 3) in the panel frame."""
        sun = np.asarray(sun_panel, dtype=float).reshape(-1, 3)
        sunlit = sun[:, 2] > SUNLIT_MIN_SZ
        alpha = np.arctan2(sun[:, 0], np.where(sunlit, sun[:, 2], 1.0))
        beta = np.arctan2(sun[:, 1], np.where(sunlit, sun[:, 2], 1.0))
        i, u = self._locate(alpha)
        j, v = self._locate(beta)
        table = self.blocked
        values = ((1 - u) * (1 - v) * table[:, i, j] + u * (1 - v) * table[:, i + 1, j]
                  + (1 - u) * v * table[:, i, j + 1] + u * v * table[:, i + 1, j + 1])
        return np.where(sunlit[:, None], values.T, 0.0)

    def choose(self, sun_panel: npt.ArrayLike, target_blocked: npt.ArrayLike) -> FloatArray:
        """Closures (N,) by the rule of :func:`.ray_casting.closure_for_shading`.

        ``sun_panel`` is (N, 3), or (W, N, 3) for a look-ahead window, judged by each
        candidate's worst blocked fraction over the window's sunlit instants.
        """
        sun = np.asarray(sun_panel, dtype=float)
        window = sun if sun.ndim == 3 else sun[None]
        blocked = np.stack([self.blocked_fractions(s) for s in window])
        lit = window[..., 2] > SUNLIT_MIN_SZ
        worst = np.where(lit[..., None], blocked, np.inf).min(axis=0)
        any_lit = cast(BoolArray, lit.any(axis=0))  # (N,): lit is (W, N)
        worst = np.where(any_lit[:, None], worst, 0.0)
        views = np.broadcast_to(self.view, worst.shape)
        target = np.broadcast_to(np.asarray(target_blocked, dtype=float), any_lit.shape)
        if not np.all((target >= 0) & (target <= 1)):
            raise ValueError('target_blocked must lie in [0, 1]')
        return self.closures[choose_candidate(self.closures, worst, views, any_lit, target)]

    def _locate(self, angle: FloatArray) -> tuple[IntArray, FloatArray]:
        grid = self.profile_rad
        step = grid[1] - grid[0]
        position = (np.clip(angle, grid[0], grid[-1]) - grid[0]) / step
        lower = np.clip(np.floor(position).astype(int), 0, grid.size - 2)
        return lower, position - lower
