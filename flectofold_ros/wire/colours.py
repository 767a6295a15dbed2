"""The facade's colours, the same in every view: Rerun, RViz and Foxglove markers, pictures.

A panel is coloured by closure on one ramp, open (0) sand to closed (1) deep blue-green, red
for a latched fault and grey before its first state (or, coloured by pressure, without a
reading). The structural sheet is coloured by strain against the allowable strain
(:func:`strain_colours`). Colours are uint8 RGBA.
"""

import numpy as np
import numpy.typing as npt

#: uint8 RGBA colours, one row per panel or vertex.
RgbaArray = npt.NDArray[np.uint8]

FAULT_RGBA = (215, 38, 38, 255)
#: A panel with no state yet (or, coloured by pressure, no pressure reading).
NO_STATE_RGBA = (128, 128, 128, 255)
#: The facade's surface behind the panels: translucent grey.
SURFACE_RGBA = (150, 150, 150, 90)
#: The arrow toward the sun.
SUN_RGBA = (255, 190, 40, 255)
#: Open (0) to closed (1): sand to deep blue-green.
_RAMP = np.array([[236, 226, 198], [122, 170, 160], [24, 78, 104]], dtype=float)


def ramp_colours(fractions: npt.ArrayLike) -> RgbaArray:
    """(N, 4) uint8 RGBA of fractions in [0, 1] on the open-to-closed ramp (clipped)."""
    return _on_ramp(_RAMP, np.clip(np.asarray(fractions, dtype=float), 0.0, 1.0))


def _on_ramp(ramp: npt.NDArray[np.float64], fraction: npt.NDArray[np.float64]) -> RgbaArray:
    """Opaque uint8 RGBA of fractions in [0, 1] of a ramp, linear between its colours."""
    position = fraction * (len(ramp) - 1)
    low = np.minimum(position.astype(int), len(ramp) - 2)
    rgb = ramp[low] + (position - low)[..., None] * (ramp[low + 1] - ramp[low])
    rgba = np.full(position.shape + (4,), 255, dtype=np.uint8)
    rgba[..., :3] = np.round(rgb)
    return rgba


#: Strain ramp: none (green), the allowable (amber), ten times the allowable and more (red).
_STRAIN_RAMP = np.array([[46, 139, 87], [240, 190, 40], [200, 30, 30]], dtype=float)
#: Multiple of the allowable strain at which the strain ramp reaches its red end.
STRAIN_RED_MULTIPLE = 10.0


def strain_colours(strain: npt.ArrayLike, allowable_strain: float) -> RgbaArray:
    """(N, 4) uint8 RGBA of surface strains against the allowable strain.

    Linear from green (no strain) to amber at the allowable, then on a logarithmic scale to
    red at :data:`STRAIN_RED_MULTIPLE` times the allowable and beyond.
    """
    if not allowable_strain > 0.0:
        raise ValueError(f'allowable_strain must be positive, got {allowable_strain!r}')
    ratio = np.abs(np.asarray(strain, dtype=float)) / allowable_strain
    position = np.where(ratio <= 1.0, ratio, 1.0 + np.log(np.maximum(ratio, 1.0))
                        / np.log(STRAIN_RED_MULTIPLE))
    # 0 ... 1 to the allowable, 1 ... 2 beyond it: halves of the three-colour ramp.
    return _on_ramp(_STRAIN_RAMP, np.clip(position, 0.0, 2.0) / 2.0)


def ramp_colour(fraction: float) -> tuple[int, ...]:
    """RGBA (uint8 tuple) of a fraction in [0, 1] on the open-to-closed ramp (clipped)."""
    return tuple(int(c) for c in ramp_colours([float(fraction)])[0])


def panel_colours(fraction: npt.NDArray[np.float64], seen: npt.NDArray[np.bool_],
                  fault: npt.ArrayLike, known: npt.ArrayLike = True) -> RgbaArray:
    """(N, 4) RGBA of panels: ``fraction`` on the ramp, red on a fault, else grey unseen.

    ``seen``: the panel has reported; ``fault``: its fault code (0: none); ``known``: its
    ``fraction`` has a value (False: grey, e.g. a pressure without a reading).
    """
    known = np.asarray(known) & np.isfinite(fraction)
    rgba = ramp_colours(np.where(known, fraction, 0.0))
    rgba[~(known & seen)] = NO_STATE_RGBA
    rgba[seen & (np.asarray(fault) != 0)] = FAULT_RGBA
    return rgba
