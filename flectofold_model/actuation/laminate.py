"""GFRP laminates of a Flectofold panel: the mid-rib, the flaps and the hinge zones.

A laminate is described by its effective in-plane Young's modulus, Poisson's ratio and
thickness; what the model needs is its plate bending stiffness ``D = E t**3 / (12 (1 - nu**2))``
[N m], the bending moment per unit width per unit curvature.

Default values [estimate]: woven E-glass/epoxy made by vacuum infusion has E of about
18-25 GPa in plane (20 GPa used) and nu of 0.12-0.15 (0.13 used); a ply of 200-300 g/m2 fabric
is 0.2-0.3 mm thick (``docs/references.md`` section 3, after textbook values). The
Flectofold papers grade stiffness by the number of plies per zone but do not publish the
lay-ups, so the thicknesses of the presets are estimates calibrated to the published pressures.

Allowable strain [estimate]: :data:`FATIGUE_ALLOWABLE_STRAIN`, the peak surface strain a zone
may see at every cycle (:mod:`.strain` compares the model's strains with it).
"""

from dataclasses import dataclass

from flectofold_model._validate import FloatOrArray, real_fields

#: Effective in-plane modulus of woven glass/epoxy by vacuum infusion [Pa] (estimate).
GFRP_YOUNGS_MODULUS_PA = 20e9
#: Poisson's ratio of woven glass/epoxy (estimate).
GFRP_POISSON_RATIO = 0.13
#: Peak surface strain a glass-fibre laminate may see at every one of about 1e7 cycles
#: (dimensionless): an illustrative fatigue strain, not a design value. Glass-fibre laminates
#: follow the normalised S-N trend ``S / S0 ~ 1 - 0.1 log10 N`` (Mandell, Reed & Samborsky,
#: "Fatigue of fiberglass wind turbine blade materials", SAND92-7005; the DOE/MSU composite
#: materials fatigue database, Mandell & Samborsky, SAND97-3002): at 1e7 cycles about 30 % of
#: the static strength. With a static failure strain of 2-3 % for E-glass laminates that is
#: about 0.7 % (``docs/references.md`` section 3).
FATIGUE_ALLOWABLE_STRAIN = 0.007
#: Largest allowable strain a laminate accepts: above the static failure strain of E-glass.
MAX_ALLOWABLE_STRAIN = 0.05


@dataclass(frozen=True)
class Laminate:
    """One zone's laminate; construction refuses non-physical values."""

    thickness_m: float
    """Laminate thickness [m]."""
    youngs_modulus_pa: float = GFRP_YOUNGS_MODULUS_PA
    """Effective in-plane Young's modulus [Pa]."""
    poisson_ratio: float = GFRP_POISSON_RATIO
    """Poisson's ratio (dimensionless)."""
    allowable_strain: float = FATIGUE_ALLOWABLE_STRAIN
    """Largest peak surface strain the zone may see in service (dimensionless), in
    ``(0, 0.05]``; the default is the fatigue estimate :data:`FATIGUE_ALLOWABLE_STRAIN`."""

    def __post_init__(self) -> None:
        real_fields(self)
        if self.thickness_m <= 0.0:
            raise ValueError(f'thickness_m must be positive, got {self.thickness_m:g} m')
        if self.youngs_modulus_pa <= 0.0:
            raise ValueError(
                f'youngs_modulus_pa must be positive (a negative stiffness cannot hold a '
                f'shape), got {self.youngs_modulus_pa:g} Pa')
        if not 0.0 <= self.poisson_ratio < 0.5:
            raise ValueError(f'poisson_ratio must lie in [0, 0.5), got {self.poisson_ratio:g}')
        if not 0.0 < self.allowable_strain <= MAX_ALLOWABLE_STRAIN:
            raise ValueError(f'allowable_strain must lie in (0, {MAX_ALLOWABLE_STRAIN:g}] '
                             f'(a strain, not a percentage), got {self.allowable_strain:g}')

    @property
    def plate_stiffness_nm(self) -> float:
        """Bending stiffness per unit width ``D = E t**3 / (12 (1 - nu**2))`` [N m]."""
        return (self.youngs_modulus_pa * self.thickness_m**3
                / (12.0 * (1.0 - self.poisson_ratio**2)))

    def surface_strain(self, curvature_per_m: FloatOrArray) -> FloatOrArray:
        """Peak surface strain ``kappa t / 2`` at a curvature [1/m] (dimensionless)."""
        return curvature_per_m * self.thickness_m / 2.0
