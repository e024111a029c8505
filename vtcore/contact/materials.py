"""Soft-layer materials and the :class:`SoftLayer` bonded to the rigid end-effector.

Young's moduli of silicone elastomers are given by their makers as the
*100 % modulus* (the secant modulus at 100 % tensile strain). For the
small strains of a press (a few tens of percent at most) we use it as the
Young's modulus, the usual engineering approximation for these soft
silicones (their stress-strain curve is nearly linear up to 100 %). Poisson's
ratio of filled silicone rubbers is 0.49-0.4999 (nearly incompressible); we use
0.49 by default, which keeps the layer's confined (oedometric) modulus finite.

Large compression (issue 35). The finite-element reference and the ``hyperelastic`` layer model use
a compressible neo-Hookean solid whose shear and bulk moduli are these small-strain values
(:attr:`SoftLayer.shear_modulus`; lambda = E nu / ((1 + nu)(1 - 2 nu))), so every model agrees
at small strain and differs only by its nonlinearity. No Yeoh or Ogden fit of a published Ecoflex
test is used: none was at hand whose coefficients could be quoted with confidence, and the
manufacturers' 100 % modulus is one point of a tension curve, not a compression one.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import InputError

_PSI = 6894.757  # Pa per psi

#: name -> {"young_modulus" (Pa), "poisson", "source"}
MATERIALS: dict[str, dict] = {
    "ecoflex_00_20": {
        "young_modulus": 8 * _PSI, "poisson": 0.49,
        "source": "Smooth-On, Ecoflex 00-20 technical bulletin: 100% modulus 8 psi (55 kPa), "
                  "Shore 00-20 (seed 001 quotes Shore 00-22); Poisson 0.49 (nearly incompressible silicone)",
    },
    "ecoflex_00_30": {
        "young_modulus": 10 * _PSI, "poisson": 0.49,
        "source": "Smooth-On, Ecoflex 00-30 technical bulletin: 100% modulus 10 psi (69 kPa)",
    },
    "ecoflex_00_50": {
        "young_modulus": 12 * _PSI, "poisson": 0.49,
        "source": "Smooth-On, Ecoflex 00-50 technical bulletin: 100% modulus 12 psi (83 kPa)",
    },
    "dragon_skin_10": {
        "young_modulus": 22 * _PSI, "poisson": 0.49,
        "source": "Smooth-On, Dragon Skin 10 technical bulletin: 100% modulus 22 psi (152 kPa)",
    },
    "dragon_skin_30": {
        "young_modulus": 86 * _PSI, "poisson": 0.49,
        "source": "Smooth-On, Dragon Skin 30 technical bulletin: 100% modulus 86 psi (593 kPa)",
    },
    "sylgard_184": {
        "young_modulus": 1.8e6, "poisson": 0.49,
        "source": "Johnston et al., J. Micromech. Microeng. 24, 035017 (2014): "
                  "1.32-2.97 MPa for 10:1 Sylgard 184 depending on cure; 1.8 MPa taken",
    },
}


@dataclass
class SoftLayer:
    """A soft layer of uniform thickness bonded to the rigid end-effector.

    thickness : float, metres (0 means no layer: the skin is bare).
    material : str, a key of :data:`MATERIALS`.
    young_modulus, poisson : float or None; override the material's values (Pa, -).
    extent : float or None, metres: radius of the layer around the patch centre
        (seed 001: a 40 mm radius disc). None: the layer ends a few millimetres
        beyond the outermost taxels. Contact outside it carries no force.

    The layer's outer surface is the end-effector surface offset by
    ``thickness`` along the taxel normals; taxels sit at its base.
    """

    thickness: float = 0.003
    material: str = "ecoflex_00_20"
    young_modulus: float | None = None
    poisson: float | None = None
    extent: float | None = None
    base: str = "bonded"
    source: str = field(default="", init=False)

    def __post_init__(self):
        if self.material not in MATERIALS:
            raise InputError(f"unknown material {self.material!r}; known: {', '.join(sorted(MATERIALS))}",
                             key="material")
        m = MATERIALS[self.material]
        self.thickness = float(self.thickness)
        if not (self.thickness >= 0.0) or self.thickness != self.thickness:
            raise InputError(f"must be >= 0 m, got {self.thickness}", key="thickness")
        e = m["young_modulus"] if self.young_modulus is None else float(self.young_modulus)
        nu = m["poisson"] if self.poisson is None else float(self.poisson)
        if not e > 0:
            raise InputError(f"must be > 0 Pa, got {e}", key="young_modulus")
        if not 0.0 <= nu < 0.5:
            raise InputError(f"must be in [0, 0.5), got {nu}", key="poisson")
        self.young_modulus, self.poisson = float(e), float(nu)
        if self.base not in ("bonded", "frictionless"):
            raise InputError(f"must be 'bonded' or 'frictionless', got {self.base!r}", key="base")
        if self.extent is not None:
            self.extent = float(self.extent)
            if not self.extent > 0:
                raise InputError(f"must be > 0 m, got {self.extent}", key="extent")
        self.source = m["source"] if (self.young_modulus == m["young_modulus"]) else "user value"

    @property
    def e_star(self) -> float:
        """Plane-strain (contact) modulus E / (1 - nu^2), pascals."""
        return self.young_modulus / (1.0 - self.poisson**2)

    @property
    def shear_modulus(self) -> float:
        """mu = E / (2 (1 + nu)), pascals: the neo-Hookean constant of the large-compression models
        (:mod:`vtcore.contact.fem_reference`), the same small-strain stiffness as the linear ones."""
        return self.young_modulus / (2 * (1 + self.poisson))

    @property
    def confined_modulus(self) -> float:
        """Oedometric modulus E (1 - nu) / ((1 + nu)(1 - 2 nu)), pascals: a thin layer's stiffness x h."""
        nu = self.poisson
        return self.young_modulus * (1 - nu) / ((1 + nu) * (1 - 2 * nu))


class LargeDeformationWarning(UserWarning):
    """A press compresses its layer beyond what the linear model describes (:data:`LARGE_COMPRESSION`)."""


#: largest compression of a layer (share of its thickness) that linear elasticity describes fairly:
#: silicones stiffen and Poisson's ratio stops being constant well before, and the papers' and this
#: project's model are linear (docs/contact.md, 'Large compression')
LARGE_COMPRESSION = 0.30


#: largest compression (share of the thickness) over which the ``hyperelastic`` layer model was
#: fitted to its finite-element reference (vtcore.contact.hyperelastic, docs/contact.md 'Large compression')
FITTED_COMPRESSION = 0.60


def compression_note(max_compression: float, thickness: float, what: str = "the press",
                     model: str = "finite_layer") -> str | None:
    """A one-line warning when ``max_compression`` (m) exceeds :data:`LARGE_COMPRESSION` of
    ``thickness`` (m), else None: the result then leaves linear elasticity behind. For
    ``model="hyperelastic"`` the limit is :data:`FITTED_COMPRESSION`, the range it was fitted over."""
    if not thickness > 0:
        return None
    ratio = float(max_compression) / float(thickness)
    if model == "hyperelastic":
        if ratio <= FITTED_COMPRESSION:
            return None
        return (f"{what} compresses the {thickness * 1e3:.3g} mm layer by {ratio:.0%} of its thickness, past the "
                f"{FITTED_COMPRESSION:.0%} the hyperelastic model was fitted to its finite-element reference over "
                "(docs/contact.md, 'Large compression'): read the stresses as qualitative")
    if ratio <= LARGE_COMPRESSION:
        return None
    return (f"{what} compresses the {thickness * 1e3:.3g} mm layer by {ratio:.0%} of its thickness (more than "
            f"{LARGE_COMPRESSION:.0%}): outside linear elasticity, where real silicone stiffens; read the "
            "stresses as qualitative (docs/contact.md, 'Large compression')")
