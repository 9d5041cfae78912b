"""What each similarity parameter means: symbol, formula and equation number from
:data:`hypate.scaling.workflow.vocabulary.similarity.PARAMETERS`, plus one sentence of physics.

The sentences live here, with the report that prints them, rather than in the workflow's
parameter table: they are prose for the reader of a report, not part of the computation.
"""
from __future__ import annotations

from collections.abc import Iterable

from hypate.scaling.workflow.vocabulary.similarity import PARAMETERS

__all__ = ["MEANINGS", "glossary_rows"]

#: One sentence of physical meaning per similarity parameter (Ch. 2-4, 6 of the reference).
MEANINGS: dict[str, str] = {
    "h/L": "Thickness ratio: how slender the panel is, which sets its bending stiffness "
           "relative to its size.",
    "M_h/L": "Mach number times thickness ratio: the piston-theory strength of the "
             "aerodynamic pressure a panel slope produces.",
    "lambda_F": "Dynamic-pressure (aeroelastic) parameter: aerodynamic stiffness against "
                "bending stiffness; flutter sets in above a critical value.",
    "DeltaT_NTx_L2/Dxx": "Thermal-load parameter: in-plane thermal force of a temperature "
                         "rise against bending stiffness; governs thermal buckling.",
    "I_L4/(Dxx_t2)": "Structural time scale: inertia against bending stiffness over the "
                     "test time, i.e. how many natural periods the test spans.",
    "Fo": "Through-thickness Fourier number: how far heat diffuses across the skin in the "
          "test time.",
    "Fo_L": "In-plane Fourier number of the cell-wall material: how far heat spreads along "
            "the panel in the test time.",
    "Vt/L": "Flow time: how many panel lengths the free stream travels during the test.",
    "Bi_F": "Fluid Biot number: convective heating by the boundary layer against conduction "
            "into the skin.",
    "Re_0": "Free-stream Reynolds number: inertial against viscous forces of the flow, which "
            "sets the boundary layer and its heat transfer.",
    "Pr_0": "Prandtl number: momentum against thermal diffusion in the gas.",
    "gamma": "Ratio of specific heats of the gas, which shapes shock and expansion "
             "pressures.",
    "Axx_L2/Dxx": "Membrane-to-bending stiffness ratio: how strongly in-plane stretching "
                  "resists large deflections.",
    "Bxx_L/Dxx": "Bending-extension coupling of a laminate (zero for a symmetric lay-up).",
    "Sxx_L2/Dxx": "Transverse-shear stiffness against bending stiffness: how much shear "
                  "deformation a thick panel adds.",
    "NTx_L2/Dxx": "Thermal membrane force at the reference temperature against bending "
                  "stiffness.",
    "MTx_L/Dxx": "Thermal bending moment against bending stiffness: bowing from a "
                 "temperature gradient through the thickness.",
    "Tw/TS": "Wall temperature over the structural reference temperature.",
    "TT/TS": "Thermal over structural reference temperature (material properties' "
             "evaluation points).",
    "T0/TS": "Stagnation temperature of the flow over the structural reference: how hot "
             "the recovery temperature drives the skin.",
    "TF/TS": "Fluid reference temperature over the structural one.",
    "Bi_ext": "External heat-flux Biot number: an applied heat flux against conduction "
              "through the skin (a scheduled heater: its time-mean absorbed flux).",
    "lambda_ext": "External pressure load against bending stiffness.",
}


def glossary_rows(names: Iterable[str]) -> list[tuple[str, str, str, str]]:
    """``(symbol, formula, equation, meaning)`` of each parameter in ``names`` (the
    similarity table's order); a name unknown to ``PARAMETERS`` gets empty cells."""
    rows = []
    for name in names:
        info = PARAMETERS.get(name)
        formula = info.formula if info is not None else ""
        equation = f"Eq. ({info.equation})" if info is not None else ""
        rows.append((name, formula, equation, MEANINGS.get(name, "")))
    return rows
