"""Similarity parameters (Eqs. 2.15, 3.26-3.28, 4.11-4.12, 6.1-6.3, 9.1) and the analytical
scaling laws (Eqs. 6.5, 9.2, 9.3, 9.5, 9.6).

A :class:`Configuration` is everything the classical dimensional analysis needs about one
test article: the panel, the free stream, the reference temperatures and the optional
loading (uniform temperature rise, external pressure and heating, reference time).
:func:`reference_quantities` evaluates the reference values of Eqs. (3.21), (3.23) and
(4.12); :func:`similarity_parameters` every similarity parameter by name (see
:data:`PARAMETERS`); :func:`compare` tabulates prototype against model. The analytical
laws of Sec. 9.1 are :func:`analytical_scaling`, :func:`structural_time_scale` and
:func:`fourier_time_scale` (:func:`matched_time` applies them to two configurations).
:func:`apply_design` builds a model configuration from named design variables and
:func:`log_mismatch` gives ``log(Pi_m / Pi_p)`` for cheap equality constraints (Eq. 9.7).

Reference temperatures (:class:`ReferenceTemperatures`)
--------------------------------------------------------
* ``T_w`` (wall): default the panel's initial (stress-free) temperature;
* ``T_S`` (structural) and ``T_T`` (thermal): default ``T_w``, the assumption
  ``T_T = T_S = T_w`` of Eq. (9.7);
* ``T_F`` (fluid): default the free-stream static temperature ``T_inf`` (Eq. 9.7).

For the Sec. 9.1 case (properties at 300 K, initial temperature 300 K) every reference
quantity is therefore evaluated at 300 K.

Definitions and deviations from the literal text
-------------------------------------------------
* ``A_xx, B_xx, D_xx = int (1, z, z^2) Qbar_11(T_S) dz``, ``S_xx = kappa int G_13 dz``
  (Eq. 3.21a, b), from :func:`hypate.solvers.laminate.laminate` at the uniform temperature ``T_S``.
* ``N_Tx`` per unit temperature rise is the x component of the thermal force resultant
  ``int Qbar(T_S) alpha(T_S) dz`` (Eq. 3.8c) for a uniform rise, with the tangent expansion
  coefficient at ``T_S``; for an isotropic plate ``E alpha h / (1 - nu)``. Eq. (3.21c) writes
  only ``Q_11 alpha_1``; the full resultant is what Table 9.3's 47.882 requires (with
  ``Q_11`` alone it would be 37.1). The reference ``N_Tx`` of Eq. (3.21c) is this value times
  ``T_S`` and ``M_Tx = N_Tx h`` (Eq. 3.21d).
* ``I = int rho(T_S) dz`` (Eq. 3.23).
* ``rho c_p`` is the thickness *average* ``(1/h) int rho c_p(T_T) dz`` (J/(m^3 K)); Eq. (4.12a)
  writes the integral, which would leave the Fourier number with a unit of 1/m.
* ``k = h / int dz / k(T_T)`` (Eq. 4.12b) with the through-thickness conductivity ``k_33`` by
  default (the only component that multiplies ``1/h^2`` in Eqs. 4.8-4.9); Eq. (4.12b) names
  ``k_11``; pass ``conductivity_axis="x"`` to :func:`reference_quantities` for it. The two
  agree for isotropic materials.
* ``Bi_F = (k_f / k) Re_0 Pr_0 V^2 / (c_p T_T)`` exactly as Eq. (6.2b), with
  ``k_f = c_p mu(T_F) / Pr_0`` (the definition of ``Pr_0``, Eq. 2.14b), which reduces to
  ``rho_inf V^3 L / (k T_T)``. The thermal Biot number of Eq. (4.11a) with the reference
  heat flux of Eq. (2.15b) is ``Bi_F h/L``.
* ``Re_0 = rho_inf V L / mu(T_F)`` (Eq. 2.14b, Sutherland viscosity).
* External heating ``q_ext`` is the explicit ``external_heat_flux`` plus, with a radiant
  heater at ``T_rad``, the absorbed incident flux ``emissivity sigma T_rad^4``;
  ``Bi_ext = q_ext h / (k T_T)`` (Eq. 6.1d), ``lambda_ext = p_ext L^3 / D_xx`` (Eq. 6.1e).
  A heater scheduled over the test (``T_rad[k]`` design variables) has no single q_ext:
  ``Bi_ext`` takes the time mean of its absorbed flux, ``emissivity sigma <T_rad(t)^4>``
  (the heat the heater delivers over the test, divided by its duration); how that heat is
  spread in time is what the schedule's J_T and J_u see, not the table.

Size: about 610 lines -- the reference quantities, the parameter table, the time mappings
and the analytical scaling all read the same :class:`ReferenceQuantities`; they are the one
definition of "similar" the workflow, the report and the laws share.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import pandas as pd
from hypate.scaling.workflow.vocabulary.configuration import (
    Configuration,
    ReferenceTemperatures,
    positive,
    scaled_panel,
)
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition, sutherland_viscosity
from hypate.solvers.laminate import laminate, strain_rotation
from hypate.solvers.panel import PanelSpec

__all__ = [
    "PARAMETERS",
    "AnalyticalScaling",
    "ReferenceQuantities",
    "analytical_scaling",
    "compare",
    "comparison_records",
    "fourier_time_scale",
    "log_mismatch",
    "matched_time",
    "time_scale",
    "TIME_SCALINGS",
    "parameter_names",
    "reference_quantities",
    "relative_difference",
    "similarity_parameters",
    "structural_time_scale",
]


# -- reference quantities -------------------------------------------------------------------------
@dataclass(frozen=True)
class ReferenceQuantities:
    """Reference values of one configuration (Eqs. 3.21, 3.23, 4.12), SI units.

    Attributes
    ----------
    length, thickness : float
        L (m) and total thickness h (m).
    A_xx, B_xx, D_xx, S_xx : float
        N/m, N, N m, N/m at T_S (Eqs. 3.21a, b).
    N_Tx_per_K : float
        Thermal force per unit uniform temperature rise, N/(m K) (see module docstring).
    N_Tx : float
        ``N_Tx_per_K * T_S`` (Eq. 3.21c), N/m.
    M_Tx : float
        ``N_Tx * h`` (Eq. 3.21d), N.
    N_Tx_delta : float or None
        ``N_Tx_per_K * delta_T`` (N/m), the thermal force of the uniform rise (Eq. 9.1a).
    mass_per_area : float
        I = int rho dz at T_S (Eq. 3.23), kg/m^2.
    rho_cp : float
        Thickness-averaged volumetric heat capacity at T_T, J/(m^3 K) (Eq. 4.12a / h).
    conductivity : float
        k at T_T (Eq. 4.12b), W/(m K).
    solid_rho_cp, solid_conductivity : float
        The same with homogenized layers (honeycomb core, stiffeners) replaced by their
        cell-wall material: the material reference of the Fourier time scale, Eq. (9.5).
    thermal_time : float
        ``rho_cp h^2 / k`` (s): the time at which Fo = 1.
    structural_time : float
        ``sqrt(I L^4 / D_xx)`` (s): the time at which ``I L^4 / (D_xx t^2) = 1``.
    temperatures : ReferenceTemperatures
        The resolved reference temperatures.
    """

    length: float
    thickness: float
    A_xx: float
    B_xx: float
    D_xx: float
    S_xx: float
    N_Tx_per_K: float
    N_Tx: float
    M_Tx: float
    N_Tx_delta: float | None
    mass_per_area: float
    rho_cp: float
    conductivity: float
    solid_rho_cp: float
    solid_conductivity: float
    thermal_time: float
    structural_time: float
    temperatures: ReferenceTemperatures

    def as_dict(self) -> dict[str, float | None]:
        out = dataclasses.asdict(self)
        temps = out.pop("temperatures")
        out.update({f"T_{k}": v for k, v in zip(("w", "S", "T", "F"), (
            temps["wall"], temps["structural"], temps["thermal"], temps["fluid"]))})
        return out


def _thermal_force_per_kelvin(panel: PanelSpec, T: float) -> float:
    """x component of int Qbar(T) alpha_tangent(T) dz: N_Tx per unit uniform rise (N/(m K))."""
    total = 0.0
    for layer in panel.layers:
        mat = layer.material
        Q, _ = mat.plane_stress_stiffness(T)
        _, deps = mat.thermal_strain(T, T)  # tangent d(eps)/dT at T, material axes
        alpha = np.array([deps[0], deps[1], 0.0])
        R = strain_rotation(layer.angle)
        sigma = R.T @ (Q @ alpha)  # global-axes thermal stress per K
        total += float(sigma[0]) * layer.thickness
    return total


def _thermal_properties(panel: PanelSpec, T: float, axis: Literal["thickness", "x"],
                        solid: bool = False) -> tuple[float, float]:
    """Thickness-averaged rho c_p and the series conductivity (Eq. 4.12) at T.

    ``solid=True`` evaluates a homogenized layer (honeycomb core, smeared stiffeners) with
    its cell-wall material (:attr:`hypate.solvers.materials.Material.base`).
    """
    h = panel.thickness
    comp = 2 if axis == "thickness" else 0
    rc = 0.0
    resistance = 0.0
    for layer in panel.layers:
        material = layer.material
        if solid and material.base is not None:
            material = material.base
        cap, _ = material.heat_capacity(T)
        k, _ = material.conductivity(T)
        rc += float(cap) * layer.thickness
        k_layer = float(k[comp])
        if k_layer <= 0.0:
            raise InputError(f"{material.name}.conductivity",
                             f"must be > 0 for the reference conductivity (Eq. 4.12b); got "
                             f"{k_layer:g}")
        resistance += layer.thickness / k_layer
    return rc / h, h / resistance


def reference_quantities(config: Configuration, *,
                         conductivity_axis: Literal["thickness", "x"] = "thickness",
                         ) -> ReferenceQuantities:
    """Reference quantities of a configuration (Eqs. 3.21, 3.23, 4.12).

    Parameters
    ----------
    config : Configuration
    conductivity_axis : {"thickness", "x"}
        Conductivity component of Eq. (4.12b): through-thickness ``k_33`` (default) or the
        literal ``k_11``.

    Returns
    -------
    ReferenceQuantities
    """
    panel = config.panel
    temps = config.resolved_temperatures()
    TS, TT = temps.structural, temps.thermal
    assert TS is not None and TT is not None  # resolved: every temperature filled in
    lam = laminate(panel, TS)  # uniform T_S: stiffness at T_S (N_T unused here)
    h = panel.thickness
    L = float(panel.length)
    D = float(lam.D[0, 0])
    if not D > 0.0:
        raise InputError("panel.layers", f"bending stiffness D_xx must be > 0; got {D:g}")
    n_per_K = _thermal_force_per_kelvin(panel, TS)
    rho_cp, k = _thermal_properties(panel, TT, conductivity_axis)
    solid_rho_cp, solid_k = _thermal_properties(panel, TT, conductivity_axis, solid=True)
    I = float(lam.I1)
    return ReferenceQuantities(
        length=L, thickness=h, A_xx=float(lam.A[0, 0]), B_xx=float(lam.B[0, 0]), D_xx=D,
        S_xx=float(lam.S[0, 0]), N_Tx_per_K=n_per_K, N_Tx=n_per_K * TS,
        M_Tx=n_per_K * TS * h,
        N_Tx_delta=None if config.delta_T is None else n_per_K * float(config.delta_T),
        mass_per_area=I, rho_cp=rho_cp, conductivity=k, solid_rho_cp=solid_rho_cp,
        solid_conductivity=solid_k,
        thermal_time=rho_cp * h * h / k, structural_time=math.sqrt(I * L**4 / D),
        temperatures=temps)


# -- similarity parameters ------------------------------------------------------------------------
@dataclass(frozen=True)
class ParameterInfo:
    """Name, formula, source equation and whether the parameter needs optional inputs."""

    name: str
    formula: str
    equation: str
    needs: str = ""  # "", "delta_T" or "time"


#: Every similarity parameter computed by :func:`similarity_parameters`, in output order.
PARAMETERS: dict[str, ParameterInfo] = {p.name: p for p in (
    ParameterInfo("h/L", "h / L", "6.1a, 9.1a"),
    ParameterInfo("M_h/L", "M_inf h / L", "6.1f"),
    ParameterInfo("lambda_F", "gamma p_inf M_inf L^3 / D_xx", "6.2a"),
    ParameterInfo("DeltaT_NTx_L2/Dxx", "Delta T N_Tx L^2 / D_xx (N_Tx per K)", "9.1a",
                  "delta_T"),
    ParameterInfo("I_L4/(Dxx_t2)", "I L^4 / (D_xx t^2)", "3.26a, 9.1b", "time"),
    ParameterInfo("Fo", "k t / (rho c_p h^2)", "4.11a, 6.3a", "time"),
    ParameterInfo("Fo_L", "k_s t / ((rho c_p)_s L^2), cell-wall material (kept by Eq. 9.5)",
                  "9.5, 9.6", "time"),
    ParameterInfo("Vt/L", "V_inf t / L", "2.15a, 6.1b", "time"),
    ParameterInfo("Bi_F", "(k_f / k) Re_0 Pr_0 V^2 / (c_p T_T)", "6.2b"),
    ParameterInfo("Re_0", "rho_inf V_inf L / mu(T_F)", "2.14b"),
    ParameterInfo("Pr_0", "c_p mu / k_f", "2.14b"),
    ParameterInfo("gamma", "c_p / c_v", "2.14b"),
    ParameterInfo("Axx_L2/Dxx", "A_xx L^2 / D_xx", "3.26d, 6.3b"),
    ParameterInfo("Bxx_L/Dxx", "B_xx L / D_xx", "3.26d, 6.1e"),
    ParameterInfo("Sxx_L2/Dxx", "S_xx L^2 / D_xx", "3.26d, 6.1e"),
    ParameterInfo("NTx_L2/Dxx", "N_Tx L^2 / D_xx (N_Tx = N_Tx per K x T_S)", "3.21c, 6.3b"),
    ParameterInfo("MTx_L/Dxx", "M_Tx L / D_xx (M_Tx = N_Tx h)", "3.21d, 6.1e"),
    ParameterInfo("Tw/TS", "T_w / T_S", "6.3c"),
    ParameterInfo("TT/TS", "T_T / T_S", "6.3c"),
    ParameterInfo("T0/TS", "T_0 / T_S (T_0 stagnation temperature)", "6.3c"),
    ParameterInfo("TF/TS", "T_F / T_S", "6.3c"),
    ParameterInfo("Bi_ext", "q_ext h / (k T_T)", "6.1d"),
    ParameterInfo("lambda_ext", "p_ext L^3 / D_xx", "6.1e"),
)}


def similarity_parameters(config: Configuration, *,
                          reference: ReferenceQuantities | None = None,
                          names: Iterable[str] | None = None) -> dict[str, float]:
    """Every similarity parameter of a configuration, by name (see :data:`PARAMETERS`).

    Parameters
    ----------
    config : Configuration
    reference : ReferenceQuantities, optional
        Precomputed :func:`reference_quantities` of ``config``.
    names : iterable of str, optional
        Subset to return (in this order); default all that apply.

    Returns
    -------
    dict
        ``{name: value}``. ``"DeltaT_NTx_L2/Dxx"`` appears only when ``config.delta_T`` is
        set and the time parameters only when ``config.time`` is set, unless requested by
        ``names`` (then a missing input raises :class:`InputError`).
    """
    ref = reference_quantities(config) if reference is None else reference
    flow = config.flow
    temps = ref.temperatures
    # resolved (reference_quantities): every temperature filled in
    assert temps.wall is not None and temps.structural is not None
    assert temps.thermal is not None and temps.fluid is not None
    L, h, D = ref.length, ref.thickness, ref.D_xx
    V = flow.velocity
    mu = float(sutherland_viscosity(temps.fluid))
    re0 = flow.density * V * L / mu
    k_f = flow.cp * mu / flow.prandtl
    out: dict[str, float] = {
        "h/L": h / L,
        "M_h/L": flow.mach * h / L,
        "lambda_F": flow.gamma * flow.pressure * flow.mach * L**3 / D,
    }
    if config.delta_T is not None:
        out["DeltaT_NTx_L2/Dxx"] = float(config.delta_T) * ref.N_Tx_per_K * L**2 / D
    if config.time is not None:
        t = float(config.time)
        out["I_L4/(Dxx_t2)"] = ref.mass_per_area * L**4 / (D * t * t)
        out["Fo"] = ref.conductivity * t / (ref.rho_cp * h * h)
        out["Fo_L"] = ref.solid_conductivity * t / (ref.solid_rho_cp * L * L)
        out["Vt/L"] = V * t / L
    out.update({
        "Bi_F": (k_f / ref.conductivity) * re0 * flow.prandtl * V * V / (flow.cp * temps.thermal),
        "Re_0": re0,
        "Pr_0": flow.prandtl,
        "gamma": flow.gamma,
        "Axx_L2/Dxx": ref.A_xx * L**2 / D,
        "Bxx_L/Dxx": ref.B_xx * L / D,
        "Sxx_L2/Dxx": ref.S_xx * L**2 / D,
        "NTx_L2/Dxx": ref.N_Tx * L**2 / D,
        "MTx_L/Dxx": ref.M_Tx * L / D,
        "Tw/TS": temps.wall / temps.structural,
        "TT/TS": temps.thermal / temps.structural,
        "T0/TS": flow.stagnation_temperature / temps.structural,
        "TF/TS": temps.fluid / temps.structural,
        "Bi_ext": config.heat_flux * h / (ref.conductivity * temps.thermal),
        "lambda_ext": float(config.external_pressure) * L**3 / D,
    })
    if names is None:
        return out
    selected: dict[str, float] = {}
    for name in names:
        if name not in out:
            if name in PARAMETERS:
                need = PARAMETERS[name].needs
                raise InputError(f"similarity.{name}", f"needs the configuration's {need} "
                                 "to be set")
            raise InputError(f"similarity.{name}", "unknown similarity parameter; known: "
                             f"{', '.join(PARAMETERS)}")
        selected[name] = out[name]
    return selected


def relative_difference(prototype: float, model: float) -> float:
    """``|model - prototype| / |prototype|`` (0 when both are 0, NaN when only the
    prototype is 0), as the percentages of Table 9.3."""
    if prototype == 0.0:
        return 0.0 if model == 0.0 else math.nan
    return abs(model - prototype) / abs(prototype)


def compare(prototype: Configuration | Mapping[str, float],
            model: Configuration | Mapping[str, float],
            names: Iterable[str] | None = None) -> pd.DataFrame:
    """Prototype vs model similarity parameters with relative differences.

    Parameters
    ----------
    prototype, model : Configuration or mapping
        Configurations, or precomputed ``{name: value}`` dictionaries.
    names : iterable of str, optional
        Parameters to compare; default those available for both.

    Returns
    -------
    pandas.DataFrame
        Columns ``name``, ``prototype``, ``model``, ``relative_difference``
        (``|model - prototype| / |prototype|``, NaN when the prototype value is 0 and the
        model's is not).
    """
    names = list(names) if names is not None else None
    pp = (similarity_parameters(prototype, names=names) if isinstance(prototype, Configuration)
          else dict(prototype))
    pm = (similarity_parameters(model, names=names) if isinstance(model, Configuration)
          else dict(model))
    order = names if names is not None else [n for n in pp if n in pm]
    rows = []
    for name in order:
        if name not in pp or name not in pm:
            raise InputError(f"similarity.{name}", "not available for both prototype and model")
        rows.append({"name": name, "prototype": float(pp[name]), "model": float(pm[name]),
                     "relative_difference": relative_difference(float(pp[name]),
                                                                float(pm[name]))})
    return pd.DataFrame(rows, columns=["name", "prototype", "model", "relative_difference"])


def comparison_records(table: pd.DataFrame) -> list[dict[str, Any]]:
    """The public JSON form of :func:`compare` (``design_point.json`` ``similarity``):
    ``[{"name", "prototype", "model", "relative_difference"}]``, NaN written as ``None``."""
    out = []
    for row in table.itertuples(index=False):
        rec: dict[str, Any] = {"name": str(row.name)}
        for key in ("prototype", "model", "relative_difference"):
            v = float(getattr(row, key))
            rec[key] = v if math.isfinite(v) else None
        out.append(rec)
    return out


# -- analytical scaling laws (Sec. 9.1.2.1) -------------------------------------------------------
def structural_time_scale(prototype: ReferenceQuantities, model: ReferenceQuantities) -> float:
    """``dt_m / dt_p`` keeping ``I L^4 / (D_xx t^2)`` equal (Eq. 9.1b).

    With ``L_m = L_p / xi`` this is Eq. (9.3):
    ``(1/xi^2) sqrt((D_p / D_m) (I_m / I_p))``.
    """
    return model.structural_time / prototype.structural_time


def fourier_time_scale(prototype: ReferenceQuantities, model: ReferenceQuantities, *,
                       xi: float | None = None,
                       rule: Literal["length", "thickness"] = "length") -> float:
    """``dt_m / dt_p`` keeping the Fourier number equal.

    ``rule="length"`` (default), Eqs. (9.5)-(9.6):
    ``(1/xi^2) k_p (rho c_p)_m / ((rho c_p)_p k_m)`` with ``xi = L_p / L_m`` (the actual
    lengths unless ``xi`` is given) and the *material* reference properties: Eq. (4.12) over
    the layup with a homogenized core evaluated with its cell-wall material
    (``solid_rho_cp``, ``solid_conductivity``). This is the dissertation's reading: Table 9.4
    lists the honeycomb sandwich as Inconel 718 throughout, Table 9.5 gives the two
    materials' properties for this ratio, and Sec. 9.2.1.2 states that a 160-s prototype
    response needs less than 40 s of tunnel time for ``xi >= 2``, i.e. a material ratio
    near one (Inconel 718 / Ti 6242: 1.024). The effective through-thickness values of the
    sandwich (0.27 W/(m K), 4.3e5 J/(m^3 K) at 300 K) would instead shorten the model's
    test to ~1 % of that and leave it unheated.

    ``rule="thickness"``, Eq. (6.5): the effective layup properties (Eq. 4.12) and
    ``(h_m / h_p)^2``.
    """
    if rule == "thickness":
        material = ((prototype.conductivity * model.rho_cp)
                    / (model.conductivity * prototype.rho_cp))
        return material * (model.thickness / prototype.thickness) ** 2
    if rule != "length":
        raise InputError("time_scaling", f"unknown Fourier rule {rule!r}")
    material = ((prototype.solid_conductivity * model.solid_rho_cp)
                / (model.solid_conductivity * prototype.solid_rho_cp))
    ratio = (model.length / prototype.length if xi is None
             else 1.0 / positive("xi", xi, "-"))
    return material * ratio**2


#: Time-scaling rules of a scaling study: the Fourier number with the length scale
#: (Eqs. 9.5-9.6), with the thickness (Eq. 6.5), or the structural time (Eq. 9.3).
TIME_SCALINGS = ("fourier", "fourier_thickness", "structural")


def time_scale(prototype: ReferenceQuantities, model: ReferenceQuantities,
               rule: str = "fourier") -> float:
    """``dt_m / dt_p`` by one of :data:`TIME_SCALINGS`."""
    if rule == "fourier":
        return fourier_time_scale(prototype, model, rule="length")
    if rule == "fourier_thickness":
        return fourier_time_scale(prototype, model, rule="thickness")
    if rule == "structural":
        return structural_time_scale(prototype, model)
    raise InputError("time_scaling", f"must be one of {', '.join(TIME_SCALINGS)}; got {rule!r}")


def matched_time(prototype: Configuration, model: Configuration, time: float,
                 rule: str = "fourier") -> float:
    """Model time (s) at the same nondimensional time as ``time`` on the prototype.

    ``rule`` is one of :data:`TIME_SCALINGS` (see :func:`time_scale`), applied with the
    actual reference quantities of the two configurations.
    """
    return time_scale(reference_quantities(prototype), reference_quantities(model),
                      rule) * float(time)


def log_mismatch(prototype: Configuration | Mapping[str, float], model: Configuration,
                 names: Sequence[str]) -> np.ndarray:
    """``log(Pi_model / Pi_prototype)`` of the named parameters, shape (len(names),).

    Zero means matched: use as cheap equality constraints (e.g. ``"TF/TS"`` and
    ``"Tw/TS"`` for Eq. 9.7). Raises :class:`InputError` for a non-positive parameter.
    """
    target = (similarity_parameters(prototype, names=names)
              if isinstance(prototype, Configuration) else prototype)
    values = similarity_parameters(model, names=names)
    out = np.empty(len(names))
    for i, name in enumerate(names):
        a, b = float(values[name]), float(target[name])
        if not (a > 0.0 and b > 0.0):
            raise InputError(f"similarity.{name}", f"log mismatch needs positive values; got "
                             f"model {a:g}, prototype {b:g}")
        out[i] = math.log(a / b)
    return out


@dataclass(frozen=True)
class AnalyticalScaling:
    """Model given by the analytical laws of Sec. 9.1 at a geometric scale xi.

    Attributes
    ----------
    xi : float
        ``L_p / L_m``.
    length, thickness : float
        ``L_m = L_p / xi`` and ``h_m = h_p / xi`` (Eq. 9.2a), m.
    pressure : float
        ``p_m = xi^3 (D_m / D_p) p_p`` (Eq. 9.2b), Pa.
    delta_T : float or None
        ``xi^2 (D_m / D_p) (N_p / N_m) Delta T_p`` (Eq. 9.2c), K; ``None`` if the prototype
        has no Delta T.
    time_scale : float
        ``dt_m / dt_p`` from Eq. (9.3).
    fourier_time_scale : float
        ``dt_m / dt_p`` from Eq. (9.6).
    time_step : float or None
        ``time_scale * dt_p`` if ``time_step`` was given, s.
    model : Configuration
        The scaled model configuration (length, thickness, leading edge scaled by 1/xi;
        static free stream at the prototype's Mach number, pressure p_m and the template's
        static temperature).
    """

    xi: float
    length: float
    thickness: float
    pressure: float
    delta_T: float | None
    time_scale: float
    fourier_time_scale: float
    time_step: float | None
    model: Configuration

    def design(self) -> dict[str, float]:
        """``{"L", "h", "p_inf", "delta_T"?, "time"?}`` in the names of
        :func:`apply_design`."""
        out = {"L": self.length, "h": self.thickness, "p_inf": self.pressure}
        if self.delta_T is not None:
            out["delta_T"] = self.delta_T
        if self.time_step is not None:
            out["time"] = self.time_step
        return out


def analytical_scaling(prototype: Configuration, model_template: Configuration, xi: float,
                       *, time_step: float | None = None) -> AnalyticalScaling:
    """Analytical aeroelastic scaling laws, Eqs. (9.2) and (9.3).

    Valid for a uniformly heated thin plate with piston-theory aerodynamics, the same Mach
    number and gamma for prototype and model. ``D`` and ``N_Tx`` of the model are those of
    the model layup evaluated at the scaled thickness ``h_p / xi`` (reference temperature of
    the model template).

    Parameters
    ----------
    prototype : Configuration
        With ``delta_T`` for Eq. (9.2c).
    model_template : Configuration
        Model layup and reference temperatures; its length and thickness are replaced.
    xi : float
        Geometric scale ``L_p / L_m`` (> 0).
    time_step : float, optional
        Prototype time step (s); default ``prototype.time``.

    Returns
    -------
    AnalyticalScaling
        The scaled model reproduces ``h/L``, ``lambda_F`` and ``DeltaT_NTx_L2/Dxx`` (and, with
        a time step, ``I_L4/(Dxx_t2)``) of the prototype exactly.
    """
    xi = positive("xi", xi, "-")
    ref_p = reference_quantities(prototype)
    L_m = ref_p.length / xi
    h_m = ref_p.thickness / xi
    panel = scaled_panel(model_template.panel, length=L_m, thickness=h_m,
                         leading_edge_length=prototype.panel.leading_edge_length / xi)
    trial = dataclasses.replace(model_template, panel=panel, delta_T=None, time=None)
    ref_m = reference_quantities(trial)
    d_ratio = ref_m.D_xx / ref_p.D_xx
    p_m = xi**3 * d_ratio * prototype.flow.pressure                       # Eq. (9.2b)
    dT_m = (None if prototype.delta_T is None else
            xi**2 * d_ratio * ref_p.N_Tx_per_K / ref_m.N_Tx_per_K * prototype.delta_T)  # (9.2c)
    scale = structural_time_scale(ref_p, ref_m)                           # Eq. (9.3)
    fscale = fourier_time_scale(ref_p, ref_m, xi=xi)                      # Eq. (9.6)
    dt_p = prototype.time if time_step is None else time_step
    dt_m = None if dt_p is None else scale * float(dt_p)
    flow = FlowCondition.from_static(prototype.flow.mach, p_m, model_template.flow.temperature)
    model = dataclasses.replace(trial, flow=flow, delta_T=dT_m, time=dt_m)
    return AnalyticalScaling(xi=xi, length=L_m, thickness=h_m, pressure=p_m, delta_T=dT_m,
                             time_scale=scale, fourier_time_scale=fscale, time_step=dt_m,
                             model=model)


def parameter_names(names: Sequence[str] | None = None) -> list[str]:
    """Validated list of parameter names (all of :data:`PARAMETERS` by default)."""
    if names is None:
        return list(PARAMETERS)
    bad = [n for n in names if n not in PARAMETERS]
    if bad:
        raise InputError(f"similarity.{bad[0]}", "unknown similarity parameter; known: "
                         f"{', '.join(PARAMETERS)}")
    return list(names)
