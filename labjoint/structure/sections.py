"""Materials and circular hollow sections of the 1-D beam elements (SI units).

>>> s = HollowCircle(od_m=0.114, wall_m=0.0038)
>>> round(s.area_m2 * 1e3, 4), round(s.inertia_m4 * 1e6, 4)
(1.3156, 1.9994)
>>> round(s.shear_coefficient(0.3), 3)
0.532
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from labjoint.errors import InputError


@dataclass(frozen=True)
class Material:
    """Isotropic linear-elastic material: Young's modulus (Pa), density (kg/m^3), Poisson's ratio."""

    E_pa: float
    rho_kg_m3: float
    nu: float = 0.3
    name: str = ""

    def __post_init__(self) -> None:
        where = f"materials.{self.name}" if self.name else "material"
        if not (np.isfinite(self.E_pa) and self.E_pa > 0):
            raise InputError(f"Young's modulus must be > 0 Pa, got {self.E_pa}", field=f"{where}.E_pa")
        if not (np.isfinite(self.rho_kg_m3) and self.rho_kg_m3 > 0):
            raise InputError(f"density must be > 0 kg/m^3, got {self.rho_kg_m3}",
                             field=f"{where}.rho_kg_m3")
        if not (-1.0 < self.nu < 0.5):
            raise InputError(f"Poisson's ratio must be in (-1, 0.5), got {self.nu}", field=f"{where}.nu")

    @property
    def G_pa(self) -> float:
        """Shear modulus E / (2 (1 + nu))."""
        return self.E_pa / (2.0 * (1.0 + self.nu))


@dataclass(frozen=True)
class HollowCircle:
    """Circular hollow section from outer diameter and wall thickness (a solid bar: wall = OD/2)."""

    od_m: float
    wall_m: float
    name: str = ""

    def __post_init__(self) -> None:
        where = f"sections.{self.name}" if self.name else "section"
        if not (np.isfinite(self.od_m) and self.od_m > 0):
            raise InputError(f"outer diameter must be > 0 m, got {self.od_m}", field=f"{where}.od_m")
        if not (np.isfinite(self.wall_m) and 0 < self.wall_m <= self.od_m / 2):
            raise InputError(f"wall must be in (0, OD/2 = {self.od_m / 2:g}] m, got {self.wall_m}",
                             field=f"{where}.wall_m")

    @property
    def id_m(self) -> float:
        return self.od_m - 2.0 * self.wall_m

    @property
    def area_m2(self) -> float:
        return float(np.pi / 4.0 * (self.od_m ** 2 - self.id_m ** 2))

    @property
    def inertia_m4(self) -> float:
        """Second moment of area about a diameter."""
        return float(np.pi / 64.0 * (self.od_m ** 4 - self.id_m ** 4))

    def shear_coefficient(self, nu: float) -> float:
        """Timoshenko shear coefficient of a hollow circle (Cowper 1966)."""
        m = self.id_m / self.od_m
        a = (1.0 + m * m) ** 2
        return float(6.0 * (1.0 + nu) * a / ((7.0 + 6.0 * nu) * a + (20.0 + 12.0 * nu) * m * m))


@dataclass(frozen=True)
class Rectangle:
    """Solid rectangular section: width ``b_m`` (out of the bending plane) and height ``h_m``
    (in it, along the transverse displacement w).

    >>> s = Rectangle(b_m=0.0254, h_m=0.00635)
    >>> round(s.area_m2 * 1e6, 2), round(s.inertia_m4 * 1e12, 1), round(s.shear_coefficient(0.33), 4)
    (161.29, 542.0, 0.8509)
    """

    b_m: float
    h_m: float
    name: str = ""

    def __post_init__(self) -> None:
        where = f"sections.{self.name}" if self.name else "section"
        for k in ("b_m", "h_m"):
            v = getattr(self, k)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"must be > 0 m, got {v}", field=f"{where}.{k}")

    @property
    def area_m2(self) -> float:
        return float(self.b_m * self.h_m)

    @property
    def inertia_m4(self) -> float:
        """Second moment of area about the axis across the width: b h^3 / 12."""
        return float(self.b_m * self.h_m ** 3 / 12.0)

    @property
    def torsion_m4(self) -> float:
        """Saint-Venant torsion constant (Roark's series, first terms; a the long side)."""
        a, c = max(self.b_m, self.h_m), min(self.b_m, self.h_m)
        return float(a * c ** 3 * (1.0 / 3.0 - 0.21 * c / a * (1.0 - c ** 4 / (12.0 * a ** 4))))

    def shear_coefficient(self, nu: float) -> float:
        """Timoshenko shear coefficient of a rectangle, 10 (1 + nu) / (12 + 11 nu) (Cowper 1966)."""
        return float(10.0 * (1.0 + nu) / (12.0 + 11.0 * nu))


@dataclass(frozen=True)
class GeneralSection:
    """A section given by its properties: area A (m^2), second moment of area I about the
    bending axis (m^4), torsion constant J (m^4; kept for the record, a planar bending
    model does not use it) and the Timoshenko shear coefficient (default 5/6)."""

    area_m2: float
    inertia_m4: float
    torsion_m4: float = 0.0
    kappa: float = 5.0 / 6.0
    name: str = ""

    def __post_init__(self) -> None:
        where = f"sections.{self.name}" if self.name else "section"
        for k, f in (("area_m2", "area_m2"), ("inertia_m4", "inertia_m4"), ("kappa", "shear_coefficient")):
            v = getattr(self, k)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"must be > 0, got {v}", field=f"{where}.{f}")
        if not (np.isfinite(self.torsion_m4) and self.torsion_m4 >= 0):
            raise InputError(f"must be >= 0, got {self.torsion_m4}", field=f"{where}.torsion_m4")

    def shear_coefficient(self, nu: float) -> float:
        return float(self.kappa)


#: the keys that say which kind of section a ``[sections.NAME]`` table describes
SECTION_KEYS = {"hollow_circle": ("od_m", "wall_m"), "rectangle": ("b_m", "h_m"),
                "general": ("area_m2", "inertia_m4")}

#: any of the sections a component may have
Section = HollowCircle | Rectangle | GeneralSection
