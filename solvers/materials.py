"""Temperature-dependent materials.

Library materials (``inconel718``, ``ti6242``, ``al7075``) are built from the data files in
``solvers/data``: the dissertation's 300 K values (Tables 7.5, 8.4, 9.5) scaled by the shape
of public temperature-dependent data, ``p(T) = p_300 * public(T) / public(300 K)``.

Every property is a :class:`Property`: a piecewise-linear table with a consistent derivative
(the slope of the segment, zero outside the table) for the Newton Jacobians. Outside its
table a property clamps to the end value, silently: the solvers keep running, and what the
structure went through (each layer's temperature range, recorded by the coupled response)
is held against :attr:`Material.valid_range` afterwards. A design that needs a property
outside its data is inadmissible unless the material declares a trusted extrapolation
(:class:`MaterialLimits`); :meth:`Property.checked` is the strict query that raises
:class:`OutsideDataError`.

Each material carries its :class:`MaterialLimits`: the service temperature and the yield
strength versus temperature (with their sources, in the library data files), and optionally
the temperature range over which its tables may be trusted beyond their data.

Materials expose what the solvers need, vectorized over temperature arrays of any shape:
plane-stress reduced stiffness ``Q(T)`` (Eq. 3.8) in material axes, transverse shear moduli,
secant thermal expansion and thermal strain, conductivity tensor diagonal (Eq. 4.2) and
volumetric heat capacity ``rho c_p``, each with its temperature derivative.

Size: about 640 lines: the Property type (interpolation, the out-of-data guard), the Material
with every vectorized property and its derivative, the library loader and the derived
materials of the shipped cases (stiffened skin, honeycomb core); one vocabulary the
structural and thermal solvers share.
"""
from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from typing import Any

import numpy as np
from hypate.solvers.errors import InputError
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]

#: Stefan-Boltzmann constant, W/(m^2 K^4).
STEFAN_BOLTZMANN = 5.670374419e-8

#: Library material names.
LIBRARY = ("inconel718", "ti6242", "al7075")

#: Property keys of an isotropic material (config files and data files).
ISOTROPIC_KEYS = ("density", "youngs_modulus", "poisson_ratio", "thermal_expansion",
                  "conductivity", "specific_heat")

#: Property keys of the limits of a library file's ``[limits]`` table.
LIMIT_KEYS = ("service_temperature", "yield_strength", "trusted_range")

#: Property keys of an orthotropic lamina (config files); 1 = fibre/x, 2 = y, 3 = thickness.
ORTHOTROPIC_KEYS = ("density", "E1", "E2", "G12", "G13", "G23", "nu12", "alpha1", "alpha2",
                    "k1", "k2", "k3", "specific_heat")

class OutsideDataError(InputError):
    """A property queried outside its table: the design that needs it is inadmissible.

    Attributes
    ----------
    temperatures : (float, float)
        Lowest and highest temperature queried (K).
    table : (float, float)
        The table's range (K).
    """

    def __init__(self, name: str, temperatures: tuple[float, float],
                 table: tuple[float, float]) -> None:
        self.temperatures, self.table = temperatures, table
        super().__init__(name, f"temperatures {temperatures[0]:.1f}-{temperatures[1]:.1f} K "
                         f"leave the property's data [{table[0]:g}, {table[1]:g}] K: a design "
                         "that needs it is inadmissible")

    def __reduce__(self):  # pickles by its fields (a pool worker raises it across processes)
        return (type(self), (self.field, self.temperatures, self.table))


@dataclass(frozen=True, eq=False)
class Property:
    """A scalar material property as a piecewise-linear table in temperature.

    Parameters
    ----------
    name : str
        Label used in warnings (``"inconel718.conductivity"``).
    T : ndarray of shape (n,)
        Strictly increasing temperatures (K); a single point means a constant.
    values : ndarray of shape (n,)
        Property values at ``T`` (SI units).
    """

    name: str
    T: Array
    values: Array

    def __post_init__(self) -> None:
        T = np.atleast_1d(np.asarray(self.T, dtype=float))
        v = np.atleast_1d(np.asarray(self.values, dtype=float))
        if T.shape != v.shape or T.ndim != 1 or T.size == 0:
            raise InputError(self.name, "temperature and value lists must have equal, "
                             "non-zero length")
        if T.size > 1 and np.any(np.diff(T) <= 0.0):
            raise InputError(self.name, "table temperatures must be strictly increasing")
        if not (np.all(np.isfinite(T)) and np.all(np.isfinite(v))):
            raise InputError(self.name, "table entries must be finite numbers")
        object.__setattr__(self, "T", T)
        object.__setattr__(self, "values", v)
        # set below (frozen: through object); declared here, they are not dataclass fields
        self._slopes: Array
        self._lookup: tuple[Array, Array]
        # segment slopes, computed once (the Newton Jacobians ask for them every iteration)
        object.__setattr__(self, "_slopes",
                           np.diff(v) / np.diff(T) if T.size > 1 else np.zeros(0))
        # derivative lookup by one searchsorted: breakpoints with the last one nudged up so
        # T == T[-1] lands on the left segment, and the slopes padded with the zero slope
        # outside the table on both sides (the same values as clip + where)
        if T.size > 1:
            bp = T.copy()
            bp[-1] = np.nextafter(T[-1], np.inf)
            ext = np.concatenate([[0.0], self._slopes, [0.0]])
            object.__setattr__(self, "_lookup", (bp, ext))

    @classmethod
    def constant(cls, name: str, value: float) -> Property:
        """A temperature-independent property."""
        return cls(name, np.array([0.0]), np.array([float(value)]))

    @property
    def is_constant(self) -> bool:
        return self.T.size == 1

    @property
    def range(self) -> tuple[float, float]:
        """Temperature range of the table (K); ``(-inf, inf)`` for a constant."""
        if self.is_constant:
            return (-math.inf, math.inf)
        return (float(self.T[0]), float(self.T[-1]))

    def __call__(self, T: ArrayLike) -> Array:
        """Value at temperatures ``T`` (any shape), clamped outside the table (silently:
        the temperatures a structure reached are checked against the data afterwards,
        module docstring)."""
        T = np.asarray(T, dtype=float)
        if self.is_constant:
            return np.full(T.shape, self.values[0])
        return np.interp(T, self.T, self.values)

    def checked(self, T: ArrayLike) -> Array:
        """Value at ``T`` where every temperature lies inside the table.

        Raises
        ------
        OutsideDataError
            A temperature outside :attr:`range` (the property would be clamped there).
        """
        T = np.asarray(T, dtype=float)
        if T.size and not self.is_constant:
            lo, hi = self.range
            t_min, t_max = float(np.min(T)), float(np.max(T))
            if t_min < lo or t_max > hi:
                raise OutsideDataError(self.name, (t_min, t_max), (lo, hi))
        return self(T)

    def derivative(self, T: ArrayLike) -> Array:
        """d(value)/dT of the interpolant: the segment slope, zero outside the table.

        At a table node the slope of the segment to its right is used (the interpolant is
        not differentiable there); at the last node the left segment's slope.
        """
        T = np.asarray(T, dtype=float)
        if self.is_constant:
            return np.zeros(T.shape)
        bp, ext = self._lookup
        return ext[np.searchsorted(bp, T, side="right")]

    def scaled(self, factor: float, name: str | None = None) -> Property:
        """The same table multiplied by ``factor``."""
        return Property(name or self.name, self.T, self.values * factor)


@dataclass(frozen=True)
class MaterialLimits:
    """What a material may go through: the limits a buildable model respects.

    Attributes
    ----------
    service_temperature : float or None
        Highest temperature of use (K), from the producer's data sheet (None: not stated).
    yield_strength : Property or None
        0.2 % yield strength (Pa) versus temperature (K) (None: not stated).
    trusted_range : (float, float) or None
        Temperatures (K) over which the material's owner trusts its property tables beyond
        their data (the clamped end values, or a table that was itself extrapolated); None:
        only the tables' own range is data.
    sources : str
        Where the limits come from.
    """

    service_temperature: float | None = None
    yield_strength: Property | None = None
    trusted_range: tuple[float, float] | None = None
    sources: str = ""

    def __post_init__(self) -> None:
        t = self.service_temperature
        if t is not None and not (math.isfinite(t) and t > 0.0):
            raise InputError("limits.service_temperature", f"must be a temperature > 0 K; "
                             f"got {t!r}")
        if self.yield_strength is not None:
            _require(self.yield_strength, lambda v: v > 0.0, "must be > 0 (Pa)")
        r = self.trusted_range
        if r is not None and not (len(r) == 2 and 0.0 < r[0] < r[1] and math.isfinite(r[1])):
            raise InputError("limits.trusted_range", f"must be [lower, upper] K with "
                             f"0 < lower < upper; got {r!r}")


@dataclass(frozen=True, eq=False)
class Material:
    """An orthotropic lamina material with temperature-dependent properties (SI units).

    Material axes: 1 and 2 in the lamina plane, 3 through the thickness. An isotropic
    material is built with :func:`isotropic`; it sets ``E1 = E2 = E``,
    ``G12 = G13 = G23 = E / (2 (1 + nu))`` and ``k1 = k2 = k3 = k``.

    ``alpha1``, ``alpha2`` are *secant* expansion coefficients from
    ``reference_temperature``: the free thermal strain between an initial temperature T0
    and T is ``alpha(T) (T - T_ref) - alpha(T0) (T0 - T_ref)``.
    """

    name: str
    density: Property
    E1: Property
    E2: Property
    nu12: Property
    G12: Property | None
    G13: Property | None
    G23: Property | None
    alpha1: Property
    alpha2: Property
    k1: Property
    k2: Property
    k3: Property
    specific_heat: Property
    reference_temperature: float = 300.0
    isotropic: bool = False
    description: str = ""
    extras: dict[str, float] = field(default_factory=dict)
    #: The solid (cell-wall) material of a homogenized core or stiffener layer; ``None``
    #: for a solid material. Used for the Fourier-number reference of Eq. (9.5).
    base: Material | None = None
    #: Service temperature, yield strength and trusted range (a derived core or stiffener
    #: layer carries its base's).
    limits: MaterialLimits = field(default_factory=MaterialLimits)

    # -- limits ---------------------------------------------------------------------
    @property
    def properties(self) -> tuple[Property, ...]:
        """Every property table of the material (the yield strength included)."""
        props = (self.density, self.E1, self.E2, self.nu12, self.G12, self.G13, self.G23,
                 self.alpha1, self.alpha2, self.k1, self.k2, self.k3, self.specific_heat,
                 self.limits.yield_strength)
        return tuple(p for p in props if p is not None)

    @property
    def data_range(self) -> tuple[float, float]:
        """Temperatures (K) inside every property table: the intersection of their ranges
        (``(-inf, inf)`` when every property is a constant)."""
        ranges = [p.range for p in self.properties]
        return (max(r[0] for r in ranges), min(r[1] for r in ranges))

    @property
    def valid_range(self) -> tuple[float, float]:
        """Temperatures (K) a design may reach without leaving the material's data: the
        declared trusted range if any, else :attr:`data_range`."""
        return self.limits.trusted_range or self.data_range

    @property
    def load_bearing(self) -> bool:
        """Whether the layer carries in-plane stress (a solid material; a honeycomb core or
        smeared stiffener, ``base`` set, is not stress-checked as a solid)."""
        return self.base is None

    def yield_at(self, T: ArrayLike) -> Array:
        """0.2 % yield strength (Pa) at ``T`` (NaN when the material states none)."""
        T = np.asarray(T, dtype=float)
        ys = self.limits.yield_strength
        return np.full(T.shape, np.nan) if ys is None else ys(T)

    # -- structural -----------------------------------------------------------------
    def _moduli(self, T: Array) -> tuple[Array, ...]:
        """E1, E2, nu12, G12, G13, G23 and their T-derivatives."""
        E1, dE1 = self.E1(T), self.E1.derivative(T)
        E2, dE2 = self.E2(T), self.E2.derivative(T)
        nu, dnu = self.nu12(T), self.nu12.derivative(T)
        if self.isotropic:
            G = E1 / (2.0 * (1.0 + nu))
            dG = dE1 / (2.0 * (1.0 + nu)) - E1 * dnu / (2.0 * (1.0 + nu) ** 2)
            return E1, dE1, E2, dE2, nu, dnu, G, dG, G, dG, G, dG
        out = [E1, dE1, E2, dE2, nu, dnu]
        for prop in (self.G12, self.G13, self.G23):
            assert prop is not None  # orthotropic: given (isotropic() alone leaves them None)
            out += [prop(T), prop.derivative(T)]
        return tuple(out)

    def plane_stress_stiffness(self, T: ArrayLike) -> tuple[Array, Array]:
        """Reduced stiffness Q (Eq. 3.8) in material axes and dQ/dT.

        Returns
        -------
        Q, dQ : ndarray of shape T.shape + (3, 3)
            Ordering (11, 22, 12) with engineering shear strain.
        """
        T = np.asarray(T, dtype=float)
        E1, dE1, E2, dE2, nu, dnu, G12, dG12, *_ = self._moduli(T)
        safe_E1 = np.where(E1 > 0.0, E1, 1.0)
        # nu21 = nu12 E2 / E1, so nu12 nu21 = nu12^2 E2 / E1 (zero when nu12 = 0, even E1 = 0).
        prod = np.where(E1 > 0.0, nu * nu * E2 / safe_E1, 0.0)
        dprod = np.where(E1 > 0.0, (2.0 * nu * dnu * E2 + nu * nu * dE2) / safe_E1
                         - nu * nu * E2 * dE1 / safe_E1**2, 0.0)
        D = 1.0 - prod
        dD = -dprod
        Q = np.zeros(T.shape + (3, 3))
        dQ = np.zeros(T.shape + (3, 3))
        Q[..., 0, 0] = E1 / D
        dQ[..., 0, 0] = dE1 / D - E1 * dD / D**2
        Q[..., 1, 1] = E2 / D
        dQ[..., 1, 1] = dE2 / D - E2 * dD / D**2
        Q[..., 0, 1] = Q[..., 1, 0] = nu * E2 / D
        dQ[..., 0, 1] = dQ[..., 1, 0] = (dnu * E2 + nu * dE2) / D - nu * E2 * dD / D**2
        Q[..., 2, 2] = G12
        dQ[..., 2, 2] = dG12
        return Q, dQ

    def lamina_values(self, T: ArrayLike) -> tuple[Array, Array, Array]:
        """Q (Eq. 3.8, material axes), [G13, G23] and the density at ``T`` without the
        temperature derivatives (the laminate integrals need only the values).

        The same numbers as :meth:`plane_stress_stiffness`, :meth:`transverse_shear_moduli`
        and :attr:`density`, from one evaluation of the property tables.
        """
        T = np.asarray(T, dtype=float)
        E1 = self.E1(T)
        E2 = E1 if self.E2 is self.E1 else self.E2(T)
        nu = self.nu12(T)
        if self.isotropic:
            G12 = G13 = G23 = E1 / (2.0 * (1.0 + nu))
        else:
            # orthotropic: given (isotropic() alone leaves them None)
            assert self.G12 is not None and self.G13 is not None and self.G23 is not None
            G12, G13, G23 = self.G12(T), self.G13(T), self.G23(T)
        safe_E1 = np.where(E1 > 0.0, E1, 1.0)
        prod = np.where(E1 > 0.0, nu * nu * E2 / safe_E1, 0.0)
        D = 1.0 - prod
        Q = np.zeros(T.shape + (3, 3))
        Q[..., 0, 0] = E1 / D
        Q[..., 1, 1] = E2 / D
        Q[..., 0, 1] = Q[..., 1, 0] = nu * E2 / D
        Q[..., 2, 2] = G12
        return Q, np.stack([G13, G23], axis=-1), self.density(T)

    def transverse_shear_moduli(self, T: ArrayLike) -> tuple[Array, Array]:
        """[G13, G23] and their derivatives, shape ``T.shape + (2,)``."""
        T = np.asarray(T, dtype=float)
        m = self._moduli(T)
        return np.stack([m[8], m[10]], axis=-1), np.stack([m[9], m[11]], axis=-1)

    def expansion(self, T: ArrayLike) -> tuple[Array, Array]:
        """Secant expansion [alpha1, alpha2] from the reference temperature and d/dT."""
        T = np.asarray(T, dtype=float)
        a = np.stack([self.alpha1(T), self.alpha2(T)], axis=-1)
        da = np.stack([self.alpha1.derivative(T), self.alpha2.derivative(T)], axis=-1)
        return a, da

    def thermal_strain(self, T: ArrayLike, T0: ArrayLike) -> tuple[Array, Array]:
        """Free thermal strain [eps1, eps2] from T0 to T and its derivative d/dT.

        ``eps = alpha(T) (T - T_ref) - alpha(T0) (T0 - T_ref)``; for a constant alpha this is
        ``alpha (T - T0)`` exactly.
        """
        T = np.asarray(T, dtype=float)
        T0 = np.broadcast_to(np.asarray(T0, dtype=float), T.shape)
        Tr = self.reference_temperature
        a, da = self.expansion(T)
        a0, _ = self.expansion(T0)
        eps = a * (T - Tr)[..., None] - a0 * (T0 - Tr)[..., None]
        deps = a + da * (T - Tr)[..., None]
        return eps, deps

    # -- thermal --------------------------------------------------------------------
    def conductivity(self, T: ArrayLike) -> tuple[Array, Array]:
        """Diagonal conductivity [k1, k2, k3] (Eq. 4.2, material axes) and d/dT."""
        T = np.asarray(T, dtype=float)
        props = (self.k1, self.k2, self.k3)
        vals: dict[int, tuple[Array, Array]] = {}
        for p in props:  # an isotropic material shares one table: evaluate it once
            if id(p) not in vals:
                vals[id(p)] = (p(T), p.derivative(T))
        return (np.stack([vals[id(p)][0] for p in props], axis=-1),
                np.stack([vals[id(p)][1] for p in props], axis=-1))

    def heat_capacity(self, T: ArrayLike) -> tuple[Array, Array]:
        """Volumetric heat capacity rho c_p (J/(m^3 K)) and its derivative d/dT."""
        T = np.asarray(T, dtype=float)
        rho, drho = self.density(T), self.density.derivative(T)
        cp, dcp = self.specific_heat(T), self.specific_heat.derivative(T)
        return rho * cp, drho * cp + rho * dcp

    # -- convenience ----------------------------------------------------------------
    def youngs_modulus(self, T: ArrayLike) -> Array:
        """E1 (the Young's modulus of an isotropic material)."""
        return self.E1(np.asarray(T, dtype=float))

    def poisson_ratio(self, T: ArrayLike) -> Array:
        return self.nu12(np.asarray(T, dtype=float))

    def properties_at(self, T: float) -> dict[str, float]:
        """Scalar summary at one temperature (for tables and the CLI)."""
        T = float(T)
        out = {"density": float(self.density(T)), "E1": float(self.E1(T)),
               "E2": float(self.E2(T)), "nu12": float(self.nu12(T)),
               "alpha1": float(self.alpha1(T)), "k1": float(self.k1(T)),
               "k3": float(self.k3(T)), "specific_heat": float(self.specific_heat(T))}
        G, _ = self.transverse_shear_moduli(T)
        out["G13"], out["G23"] = float(G[0]), float(G[1])
        return out


# -- constructors -------------------------------------------------------------------
def as_property(name: str, spec: float | ArrayLike | Property) -> Property:
    """A :class:`Property` from a constant or a sequence of ``(T, value)`` pairs."""
    if isinstance(spec, Property):
        return spec
    if isinstance(spec, (int, float)) and not isinstance(spec, bool):
        return Property.constant(name, float(spec))
    arr = np.asarray(spec, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] < 1:
        raise InputError(name, "must be a number or a list of [temperature, value] pairs")
    return Property(name, arr[:, 0], arr[:, 1])


def _require(prop: Property, ok: Any, message: str) -> None:
    """Raise InputError naming the property unless ``ok(values)`` holds for every entry."""
    if not np.all(ok(prop.values)):
        raise InputError(prop.name, message)


def isotropic(name: str, density: Any, youngs_modulus: Any, poisson_ratio: Any,
              thermal_expansion: Any, conductivity: Any, specific_heat: Any,
              reference_temperature: float = 300.0, description: str = "") -> Material:
    """An isotropic material; each property a constant, ``(T, value)`` pairs or a Property."""
    p = {k: as_property(f"{name}.{k}", v) for k, v in dict(
        density=density, youngs_modulus=youngs_modulus, poisson_ratio=poisson_ratio,
        thermal_expansion=thermal_expansion, conductivity=conductivity,
        specific_heat=specific_heat).items()}
    for key in ("density", "youngs_modulus", "conductivity", "specific_heat"):
        _require(p[key], lambda v: v > 0.0, "must be > 0")
    _require(p["poisson_ratio"], lambda v: (v > -1.0) & (v < 0.5), "must be in (-1, 0.5)")
    k = p["conductivity"]
    return Material(name=name, density=p["density"], E1=p["youngs_modulus"],
                    E2=p["youngs_modulus"], nu12=p["poisson_ratio"], G12=None, G13=None,
                    G23=None, alpha1=p["thermal_expansion"], alpha2=p["thermal_expansion"],
                    k1=k, k2=k, k3=k, specific_heat=p["specific_heat"],
                    reference_temperature=reference_temperature, isotropic=True,
                    description=description)


def orthotropic(name: str, reference_temperature: float = 300.0, description: str = "",
                **props: Any) -> Material:
    """An orthotropic lamina from the keys of :data:`ORTHOTROPIC_KEYS`."""
    missing = [k for k in ORTHOTROPIC_KEYS if k not in props]
    if missing:
        raise InputError(f"materials.{name}", f"orthotropic material needs {', '.join(missing)}")
    p: dict[str, Any] = {k: as_property(f"{name}.{k}", props[k]) for k in ORTHOTROPIC_KEYS}
    for key in ("density", "specific_heat"):
        _require(p[key], lambda v: v > 0.0, "must be > 0")
    for key in ("E1", "E2", "G12", "G13", "G23", "k1", "k2", "k3"):
        _require(p[key], lambda v: v >= 0.0, "must be >= 0")
    return Material(name=name, reference_temperature=reference_temperature,
                    description=description, isotropic=False, **p)


def _load_library_file(name: str) -> dict[str, Any]:
    text = resources.files("hypate.solvers").joinpath("data", f"{name}.toml").read_text()
    return tomllib.loads(text)


@cache
def library_material(name: str) -> Material:
    """A library material by name (see :data:`LIBRARY`)."""
    if name not in LIBRARY:
        raise InputError("material", f"unknown material {name!r}; library materials are "
                         f"{', '.join(LIBRARY)}")
    data = _load_library_file(name)
    Tref = float(data["reference_temperature"])
    props: dict[str, Property] = {}
    for key in ISOTROPIC_KEYS:
        shape = data["shape"][key]
        public = Property(f"{name}.{key}", np.array(shape["T"]), np.array(shape["value"]))
        factor = data["at_300K"][key] / float(public(300.0))
        props[key] = public.scaled(factor)
    material = isotropic(name, reference_temperature=Tref,
                         description=f"library material {name} (solvers/data/{name}.toml)",
                         **props)
    return dataclasses.replace(material, limits=limits_from_table(name, data.get("limits", {})))


def limits_from_table(name: str, table: dict[str, Any]) -> MaterialLimits:
    """:class:`MaterialLimits` of a ``[limits]`` table (a library file's, or a case or study
    file's ``[materials.NAME]`` keys): ``service_temperature`` (K), ``yield_strength`` (Pa:
    a number, ``[[T, value], ...]`` pairs, or a library file's ``{T = [...], value = [...]}``),
    ``trusted_range`` ([lower, upper] K), ``sources`` (text)."""
    ys = table.get("yield_strength")
    if isinstance(ys, dict):
        ys = Property(f"{name}.yield_strength", np.array(ys["T"], float),
                      np.array(ys["value"], float))
    elif ys is not None:
        ys = as_property(f"{name}.yield_strength", ys)
    tr = table.get("trusted_range")
    try:
        return MaterialLimits(
            service_temperature=(None if table.get("service_temperature") is None
                                 else float(table["service_temperature"])),
            yield_strength=ys,
            trusted_range=None if tr is None else (float(tr[0]), float(tr[1])),
            sources=str(table.get("sources", "")))
    except InputError as exc:
        raise InputError(f"materials.{name}.{exc.field.split('.', 1)[-1]}", exc.message) \
            from None


def homogenized_stiffener(base: Material, t1: float, l1: float, t2: float, l2: float,
                          name: str = "stiffener") -> Material:
    """Stiffeners smeared into a homogeneous orthotropic layer, Eqs. (8.10)-(8.11).

    ``t1``, ``l1``: thickness and spacing of the x-direction stiffeners; ``t2``, ``l2``: of the
    y-direction stiffeners (``t = 0`` for none). ``nu12 = G12 = 0`` as in Eq. (8.10).
    """
    for key, val in (("t1", t1), ("t2", t2), ("l1", l1), ("l2", l2)):
        if not (val >= 0.0 and math.isfinite(val)):
            raise InputError(f"materials.{name}.{key}", "must be >= 0 (m)")
    c1 = t1 / (t1 + l2) if t1 > 0 else 0.0  # Eq. (8.11)
    c2 = t2 / (t2 + l1) if t2 > 0 else 0.0
    c3 = c1 + c2
    if c3 <= 0.0:
        raise InputError(f"materials.{name}", "at least one of t1, t2 must be positive")
    G = _shear_modulus_property(base)
    zero = Property.constant(f"{name}.zero", 0.0)
    return Material(
        name=name, density=base.density.scaled(c3), E1=base.E1.scaled(c1),
        E2=base.E1.scaled(c2), nu12=zero, G12=zero, G13=G.scaled(c1), G23=G.scaled(c2),
        alpha1=base.alpha1, alpha2=base.alpha1, k1=base.k1.scaled(c1), k2=base.k1.scaled(c2),
        k3=base.k1.scaled(c3), specific_heat=base.specific_heat,
        reference_temperature=base.reference_temperature,
        description=f"stiffeners of {base.name} homogenized (Eq. 8.10): c1={c1:.4g}, c2={c2:.4g}",
        extras={"c1": c1, "c2": c2, "c3": c3}, base=base, limits=base.limits)


def _shear_modulus_property(base: Material) -> Property:
    """G = E / (2 (1 + nu)) of an isotropic base, tabulated where both E and nu are tabulated."""
    if not base.isotropic:
        assert base.G13 is not None
        return base.G13
    if base.E1.is_constant and base.nu12.is_constant:
        return Property.constant(f"{base.name}.G", float(
            base.E1.values[0] / (2.0 * (1.0 + base.nu12.values[0]))))
    lo = max(base.E1.range[0], base.nu12.range[0])
    hi = min(base.E1.range[1], base.nu12.range[1])
    grid = np.union1d(base.E1.T, base.nu12.T)
    grid = grid[(grid >= lo) & (grid <= hi)]
    return Property(f"{base.name}.G", grid, base.E1(grid) / (2.0 * (1.0 + base.nu12(grid))))


def air_conductivity(T: ArrayLike) -> Array:
    """Thermal conductivity of air (W/(m K)), Sutherland's law for conductivity
    (k0 = 0.0241 W/(m K) at 273.15 K, S = 194 K)."""
    T = np.asarray(T, dtype=float)
    return 0.0241 * (T / 273.15) ** 1.5 * (273.15 + 194.0) / (T + 194.0)


def honeycomb_core(base: Material, relative_density: float, cell_size: float,
                   core_thickness: float, wall_emissivity: float = 0.8,
                   name: str = "honeycomb", T_grid: ArrayLike | None = None) -> Material:
    """Hexagonal honeycomb core that carries transverse shear only (Sec. 9.2.1.1).

    * In-plane: negligible stiffness (E1 = E2 = 1e-6 E_s, nu12 = G12 = 0), so the core only
      transfers load between the sheets through shear.
    * Transverse shear (Gibson & Ashby, regular hexagons, the "analytical relation" of
      Ref. [203]): ``G13 = G23 = 0.5 * rho_rel * G_s``, from
      ``G13/G_s = (t/l) cos(30) / (1 + sin(30))`` and ``rho_rel = (2/sqrt(3)) t/l``.
    * Through-thickness conductivity (Swann & Pittman, NASA TN D-714, Ref. [205]): solid
      conduction ``rho_rel k_s`` + air in the cells + radiation
      ``4 sigma F T^3 L`` with ``F = 0.664 (L/D)^-0.69 eps^0.63``; it rises with temperature.
      In-plane conductivity is taken as half the solid term plus the air term.
    * Density ``rho_rel rho_s``; specific heat of the base material.

    Parameters
    ----------
    base : Material
        The foil material (isotropic).
    relative_density : float
        rho_core / rho_s, in (0, 0.3].
    cell_size : float
        Cell diameter D (m), across flats.
    core_thickness : float
        Core depth L (m), the radiation path length.
    wall_emissivity : float
        Emissivity of the cell walls, in (0, 1].
    """
    if not (0.0 < relative_density <= 0.3):
        raise InputError(f"materials.{name}.relative_density", "must be in (0, 0.3]")
    if not (cell_size > 0.0):
        raise InputError(f"materials.{name}.cell_size", "must be > 0 (m)")
    if not (core_thickness > 0.0):
        raise InputError(f"materials.{name}.core_thickness", "must be > 0 (m)")
    if not (0.0 < wall_emissivity <= 1.0):
        raise InputError(f"materials.{name}.wall_emissivity", "must be in (0, 1]")
    if T_grid is None:
        lo, hi = base.k1.range
        T_grid = np.linspace(max(lo, 200.0), min(hi, 1500.0), 21)
    grid = np.asarray(T_grid, dtype=float)
    G = _shear_modulus_property(base)
    Gc = G.scaled(0.5 * relative_density, f"{name}.G13")
    F = 0.664 * (core_thickness / cell_size) ** -0.69 * wall_emissivity**0.63
    k_air = (1.0 - relative_density) * air_conductivity(grid)
    k_rad = 4.0 * STEFAN_BOLTZMANN * F * grid**3 * core_thickness
    k_solid = relative_density * base.k1(grid)
    k3 = Property(f"{name}.k3", grid, k_solid + k_air + k_rad)
    k_in = Property(f"{name}.k_in", grid, 0.5 * k_solid + k_air)
    tiny = base.E1.scaled(1e-6, f"{name}.E")
    zero = Property.constant(f"{name}.zero", 0.0)
    return Material(
        name=name, density=base.density.scaled(relative_density), E1=tiny, E2=tiny,
        nu12=zero, G12=zero, G13=Gc, G23=Gc, alpha1=base.alpha1, alpha2=base.alpha1,
        k1=k_in, k2=k_in, k3=k3, specific_heat=base.specific_heat,
        reference_temperature=base.reference_temperature,
        description=(f"{base.name} honeycomb core, rho_rel={relative_density:g}, D={cell_size:g} m,"
                     f" L={core_thickness:g} m (Gibson-Ashby shear, Swann-Pittman conductivity)"),
        extras={"relative_density": relative_density, "radiation_factor": F}, base=base,
        limits=base.limits)
