"""Coupled aerothermoelastic model and the tightly coupled quasi-steady scheme (Ch. 5).

:class:`PanelModel` holds the three disciplines of one panel in one flow -- the DCS9
structure, the HTSH thermal model and a fluid model of any fidelity -- joined by the
conservative transfer matrices of Eq. (5.1). It provides the discipline couplings the
schemes need: aerodynamic loads and their Jacobians on the structural DOFs, the wall heat
flux as an implicit function of the wall temperature, the static aeroelastic equilibrium
(Eq. 5.31b) by Newton with the aerodynamic Jacobian, and the linearized stability analysis
(Eqs. 5.33-5.35).

:func:`run_tc` integrates Eq. (5.31) on the thermal time scale (Sec. 5.4.3): each step a
Crank-Nicolson thermal step with the aerodynamic heat flux implicit in the wall
temperature, then the aeroelastic equilibrium with fluid and structure converged together,
optionally repeated (fixed-point passes) until both fields stop changing; then the LSA.
The run stops after ``unstable_steps`` consecutive unstable LSA results.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypate.solvers.aero.analytic import PointwiseJacobians
from hypate.solvers.aero.base import FluidLoads, FluidModel, SurfaceState
from hypate.solvers.aero.factory import make_fluid_model
from hypate.solvers.coupling.response import Response, sinusoidal_modes
from hypate.solvers.coupling.stability import (
    StabilityResult,
    gep,
    pep,
    shift_invert_gep,
    start_vector,
)
from hypate.solvers.coupling.transfer import Transfer, fluid_points
from hypate.solvers.errors import InputError
from hypate.solvers.flow import FlowCondition
from hypate.solvers.numerics.sparse import gmres
from hypate.solvers.numerics.threads import single_threaded_blas
from hypate.solvers.panel import PanelSpec
from hypate.solvers.structure.dynamics import AlphaStepper
from hypate.solvers.structure.model import StructuralModel
from hypate.solvers.thermal.model import SurfaceCondition, ThermalLoads, ThermalModel
from numpy.typing import NDArray

Array = NDArray[np.float64]


@dataclass(frozen=True)
class CouplingSettings:
    """Settings of a coupled run (SI units).

    Attributes
    ----------
    time_step, duration : float
        s.
    radiation_temperature : float or None
        Surroundings of the upper-surface radiation (K); None = free-stream temperature.
        A radiant heater of the scaling problem sets this to T_rad.
    external_pressure : float
        Uniform pressure on the panel's lower surface minus p_inf (Pa): positive pushes
        the panel towards +z (into the flow).
    external_heat_flux : float
        Uniform external heat flux q_ext (W/m^2) absorbed by the upper surface (a design
        or what-if value; a radiant heater is ``radiation_temperature``), the q_ext of
        ``Bi_ext = q_ext h / (k T_T)`` (Eq. 6.1d): added to the fluid heat flux delivered to
        the thermal model, ``Q = H_TF (q + q_ext)`` (Eq. 5.1b). Not ramped by ``run_lc``'s
        ``ramp_time`` and not part of the recorded (fluid) heat flux. 0 = none (the results
        are exactly those without it).
    lsa_modes : int
        Eigenvalues computed per LSA.
    lsa_every : int
        LSA every this many steps (1 = every step).
    unstable_steps : int
        Consecutive unstable LSA results that end the run.
    passes : int
        Maximum thermal/aeroelastic fixed-point passes per step (1 = one of each).
    pass_tol : float
        Relative change of T and u that ends the passes.
    newton_rtol : float
        Residual tolerance of the aeroelastic Newton (relative to the load scale).
    newton_max_iter : int
    fluid_density : int
        Fluid points per shell-node spacing (transfer grid).
    thermal_alpha : float
        Crank-Nicolson alpha-bar.
    keep_fields : bool
        Store nodal u and T for every step in the response.
    initial_temperature_rise : float
        Uniform temperature rise (K) of the panel at t = 0 over its stress-free initial
        temperature (the uniformly heated panel of Sec. 9.1).
    initial_deflection : float
        Amplitude of an initial deflection ``w0 = A h sin(pi x/a) sin(pi y/b)`` in units of
        the thickness (a perturbation that lets a flat heated panel leave the trivial state).
    """

    time_step: float = 1.0
    duration: float = 160.0
    radiation_temperature: float | None = None
    external_pressure: float = 0.0
    external_heat_flux: float = 0.0
    lsa_modes: int = 6
    lsa_every: int = 1
    unstable_steps: int = 2
    passes: int = 1
    pass_tol: float = 1e-5
    newton_rtol: float = 1e-8
    newton_max_iter: int = 30
    fluid_density: int = 2
    thermal_alpha: float = 0.5
    keep_fields: bool = True
    initial_temperature_rise: float = 0.0
    initial_deflection: float = 0.0

    def __post_init__(self) -> None:
        if not (self.time_step > 0 and math.isfinite(self.time_step)):
            raise InputError("simulation.time_step", "must be > 0 (s)")
        if not (self.duration >= self.time_step):
            raise InputError("simulation.duration", "must be at least one time_step")
        if self.unstable_steps < 1:
            raise InputError("simulation.unstable_steps", "must be >= 1")
        if self.passes < 1:
            raise InputError("simulation.passes", "must be >= 1")
        if not math.isfinite(self.external_heat_flux):
            raise InputError("simulation.external_heat_flux", "must be finite (W/m^2)")

    @property
    def n_steps(self) -> int:
        return int(round(self.duration / self.time_step))


@dataclass
class StepTimer:
    """Wall time per discipline (s), accumulated over a run (Table 8.6 style)."""

    fluid: float = 0.0
    structural: float = 0.0
    thermal: float = 0.0
    stability: float = 0.0
    factorizations: int = 0

    def as_dict(self) -> dict[str, float]:
        return {"fluid": self.fluid, "structural": self.structural, "thermal": self.thermal,
                "stability": self.stability}


class EquilibriumError(RuntimeError):
    """The static aeroelastic equilibrium did not converge (e.g. past a snap-through)."""


def _pattern_keys(indptr: NDArray[np.integer], indices: NDArray[np.integer],
                  n_cols: int) -> NDArray[np.int64]:
    rows = np.repeat(np.arange(indptr.size - 1, dtype=np.int64), np.diff(indptr))
    return rows * n_cols + indices.astype(np.int64)


def triple_product_operator(L: sp.spmatrix, R: sp.spmatrix,
                            pattern: tuple[NDArray, NDArray] | None = None
                            ) -> tuple[sp.csr_matrix, NDArray, NDArray]:
    """The linear map ``d -> data of L diag(d) R`` on a fixed CSR pattern.

    ``L`` is (m, n_f), ``R`` (n_f, k). Returns ``(T, indptr, indices)`` with ``T`` sparse of
    shape (nnz, n_f), so ``csr_matrix((T @ d, indices, indptr), (m, k))`` equals
    ``L @ diag(d) @ R`` (up to round-off: the products are summed in another order). The
    pattern is ``pattern = (indptr, indices)`` when given (it must contain every entry of
    the product), else the product's own. The data of a pointwise aerodynamic Jacobian
    transferred to the structure is linear in the pointwise derivatives, so it costs one
    sparse mat-vec instead of two sparse matrix products per evaluation.
    """
    Lc = sp.coo_matrix(L)
    Rr = sp.csr_matrix(R)
    Rr.sort_indices()
    m, k = Lc.shape[0], Rr.shape[1]
    counts = np.diff(Rr.indptr)[Lc.col]
    rep = np.repeat(np.arange(Lc.nnz), counts)
    start = np.repeat(Rr.indptr[Lc.col], counts)
    offs = np.arange(rep.size) - np.repeat(np.cumsum(counts) - counts, counts)
    ridx = start + offs
    keys = Lc.row[rep].astype(np.int64) * k + Rr.indices[ridx].astype(np.int64)
    vals = Lc.data[rep] * Rr.data[ridx]
    f = Lc.col[rep]
    if pattern is None:
        uniq = np.unique(keys)
        rows = uniq // k
        indices = (uniq % k).astype(np.int32)
        indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=m))]).astype(
            np.int32)
        pkeys = uniq
    else:
        indptr, indices = pattern
        pkeys = _pattern_keys(indptr, indices, k)
    pos = np.minimum(np.searchsorted(pkeys, keys), pkeys.size - 1)
    if not np.all(pkeys[pos] == keys):
        raise ValueError("the product has entries outside the given pattern")
    T = sp.csr_matrix((vals, (pos, f)), shape=(pkeys.size, Lc.shape[1]))
    T.sum_duplicates()
    return T, indptr, indices


class _FreePattern:
    """The free-DOF block of matrices on the structural CSR pattern, by index maps.

    ``sel`` picks the free-free entries (in CSR order of the block), ``tpos`` reorders the
    block's CSR data into CSC data (the pattern is structurally symmetric), so
    ``A[free][:, free]`` in CSR or CSC costs one gather; ``diag`` picks the block's
    diagonal from its CSR data.
    """

    def __init__(self, indptr: NDArray, indices: NDArray, n: int, free: NDArray) -> None:
        newpos = np.full(n, -1, dtype=np.int64)
        newpos[free] = np.arange(free.size)
        rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr))
        r, c = newpos[rows], newpos[indices]
        keep = (r >= 0) & (c >= 0)
        self.sel = np.flatnonzero(keep)
        r, c = r[keep], c[keep]
        self.n = int(free.size)
        self.indices = c.astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=self.n))]
                                     ).astype(np.int32)
        keys = r * self.n + c
        tkeys = c * self.n + r
        self.tpos = np.searchsorted(keys, tkeys)
        self.diag = np.flatnonzero(r == c)  # the diagonal entries, in row order
        if not np.array_equal(keys[self.tpos], tkeys):
            raise ValueError("the structural pattern is not structurally symmetric")
        self._perm: tuple[NDArray, NDArray, NDArray, NDArray] | None = None

    def csc_from_block(self, block: Array) -> sp.csc_matrix:
        """CSC of the block with CSR data ``block``: column j holds the entries (i, j), and
        with the symmetric pattern its row indices are the CSR column indices of row j."""
        return sp.csc_matrix((block[self.tpos], self.indices, self.indptr),
                             shape=(self.n, self.n))

    def _ordering(self) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """The minimum-degree ordering of ``A^T + A`` (SuperLU's ``MMD_AT_PLUS_A``) and the
        CSC pattern of the permuted block ``A[p][:, p]`` with the gather map from the
        block's CSR data, computed once (the ordering depends on the pattern only)."""
        if self._perm is None:
            n, nnz = self.n, self.indices.size
            # a diagonally dominant matrix on the pattern: no pivoting, so perm_c is MMD's
            ones = self.csc_from_block(np.ones(nnz)) + n * sp.identity(n, format="csc")
            perm_c = spla.splu(ones.tocsc(), permc_spec="MMD_AT_PLUS_A",
                               diag_pivot_thresh=1e-3, options={"SymmetricMode": True}).perm_c
            p = np.argsort(perm_c)  # perm_c[old] = new, p[new] = old
            # entry positions (1-based: no entry may vanish) carried through the permutation
            pos = sp.csr_matrix((np.arange(1.0, nnz + 1.0), self.indices, self.indptr),
                                shape=(n, n))
            P = pos[p][:, p].tocsc()
            P.sort_indices()
            self._perm = (p, P.data.astype(np.int64) - 1, P.indices, P.indptr)
        return self._perm

    def factor(self, block: Array) -> PermutedLU | spla.SuperLU:
        """:func:`splu_free` of the block with CSR data ``block``, on the pre-permuted block.

        SuperLU then skips its ordering (``NATURAL``): the same factor as the
        ``MMD_AT_PLUS_A`` path, 20 % faster on the 8 x 8 shell (measured). Same check and
        fallback as :func:`splu_free`. Returns an object with ``solve`` and ``shape``.
        """
        p, gather, indices, indptr = self._ordering()
        B = sp.csc_matrix((block[gather], indices, indptr), shape=(self.n, self.n))
        try:
            lu = PermutedLU(spla.splu(B, permc_spec="NATURAL", diag_pivot_thresh=1e-3,
                                      options={"SymmetricMode": True}), p)
        except RuntimeError:
            return spla.splu(self.csc_from_block(block))
        A = sp.csr_matrix((block, self.indices, self.indptr), shape=(self.n, self.n))
        if _factor_ok(lu, A):
            return lu
        return spla.splu(self.csc_from_block(block))


class PermutedLU:
    """A sparse LU ``lu`` of ``A[p][:, p]`` used as a solver of ``A``: ``A x = b`` is
    ``(A[p][:, p]) x[p] = b[p]``."""

    def __init__(self, lu: spla.SuperLU, p: NDArray) -> None:
        self.lu, self.p = lu, p
        self.shape = lu.shape

    def solve(self, b: Array) -> Array:
        x = np.empty_like(b, dtype=float)
        x[self.p] = self.lu.solve(np.asarray(b, dtype=float)[self.p])
        return x


def _factor_ok(lu: PermutedLU | spla.SuperLU, A: sp.spmatrix) -> bool:
    """One check solve (relative residual <= 1e-10): catches a pivot the symmetric mode's
    threshold let through."""
    b = np.cos(np.arange(A.shape[0], dtype=float))  # a fixed, nowhere-special vector
    x = lu.solve(b)
    return bool(np.all(np.isfinite(x))
                and np.linalg.norm(A @ x - b) <= 1e-10 * np.linalg.norm(b))


def splu_free(A: sp.csc_matrix):
    """Sparse LU of a free-DOF block ``K - K_A (- sigma M)``.

    SuperLU's symmetric mode with the minimum-degree ordering of ``A^T + A`` (diagonal
    pivots preferred, threshold 1e-3) -- the pattern is structurally symmetric and the
    matrix close to symmetric: 3 ms and 2.5x fewer nonzeros than the default COLAMD with
    partial pivoting (8 ms) on the 8 x 8 shell (measured). The factor is checked on one
    solve (relative residual <= 1e-10); when the symmetric mode reports a singular factor
    or fails the check (a pivot the threshold let through), the default LU is used.
    """
    try:
        lu = spla.splu(A, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=1e-3,
                       options={"SymmetricMode": True})
    except RuntimeError:
        return spla.splu(A)
    if _factor_ok(lu, A):
        return lu
    return spla.splu(A)


class DeferredMatrix:
    """A sparse matrix formed on first use: calling it returns the matrix (the thermal
    Newton resolves a flux derivative only when it needs the Jacobian); ``@``,
    ``toarray()`` and ``tocsr()`` act on the matrix."""

    def __init__(self, build, shape: tuple[int, int]) -> None:
        self._build = build
        self._matrix: sp.csr_matrix | None = None
        self.shape = shape

    def __call__(self) -> sp.csr_matrix:
        if self._matrix is None:
            self._matrix = self._build()
        return self._matrix

    def __matmul__(self, x):
        return self() @ x

    def toarray(self) -> Array:
        return self().toarray()

    def tocsr(self) -> sp.csr_matrix:
        return self()


class PanelModel:
    """A panel in a flow: structure, thermal model, fluid model and transfer (Eq. 5.1).

    Parameters
    ----------
    panel : PanelSpec
    flow : FlowCondition
    fluid : FluidModel
    settings : CouplingSettings
    structure : StructuralModel, optional
        Reused when given (same panel).
    """

    def __init__(self, panel: PanelSpec, flow: FlowCondition, fluid: FluidModel,
                 settings: CouplingSettings | None = None,
                 structure: StructuralModel | None = None) -> None:
        self.panel = panel
        self.flow = flow
        self.fluid = fluid
        self.settings = settings or CouplingSettings()
        self.structure = structure if structure is not None else StructuralModel(panel)
        self.thermal = ThermalModel(panel)
        self.points = fluid_points(panel, self.settings.fluid_density)
        self.transfer = Transfer.build(panel, self.points, self.thermal.n_levels)
        tr = self.transfer
        n_in = self.thermal.n_inplane
        top = self.thermal.mesh.top_nodes
        # wall temperature from the top-level nodes only; the fluid heat input goes back as
        # nodal loads on them (Eq. 5.1b)
        self._H_FT_top = tr.H_FT[:, top].tocsr()
        self._H_TF_top = tr.H_TF[top, :].tocsr()
        self._n_in = n_in
        self.timer = StepTimer()
        s = self.settings
        self.T_rad = float(flow.temperature if s.radiation_temperature is None
                           else s.radiation_temperature)
        self._F_ext = (self.structure.pressure_load(s.external_pressure)
                       if s.external_pressure != 0.0 else np.zeros(self.structure.n_dof))
        self.modes = sinusoidal_modes(panel, self.points)
        self._precond = None  # LU of a recent (K - K_A)_ff, preconditions the Newton solves
        self._ops: dict[str, object] | None = None  # pointwise-Jacobian operators (lazy)
        self._last_state: tuple | None = None  # (u, T, K, loads, ...) of the last residual
        self._lsa_start: Array | None = None  # Arnoldi start of the next LSA (last modes)

    def _op(self, name: str):
        """Operators of the pointwise (diagonal) aerodynamic Jacobians, each built once on
        first use.

        ``KA_slope``/``KA_w``: d -> data of ``H_SF diag(d) H_FS_slope`` / ``H_SF diag(d) H_FS``
        on the structural pattern (K_A and C_A, Eq. 5.34, for the solvers); ``KA_slope_own``/
        ``KA_w_own``: the same on the products' own (compact) patterns, with their
        ``(T, indptr, indices)``; ``QT_a``/``QT_b``: a, b -> data of ``H_TF diag(a) H_FT`` and
        ``H_TF diag(b) S H_FT`` on the top thermal nodes (the implicit wall-flux derivative)
        on ``QT_pattern``; ``free``: the free-DOF block maps of the structural pattern.
        """
        ops = self._ops if self._ops is not None else {}
        self._ops = ops
        if name in ops:
            return ops[name]
        st, tr = self.structure, self.transfer
        H = {"slope": tr.H_FS_slope, "w": tr.H_FS}
        if name in ("KA_slope", "KA_w"):
            ops[name] = triple_product_operator(tr.H_SF, H[name[3:]],
                                                (st._indptr, st._indices))[0]
        elif name in ("KA_slope_own", "KA_w_own"):
            ops[name] = triple_product_operator(tr.H_SF, H[name[3:-4]])
        elif name in ("QT_a", "QT_b", "QT_pattern"):
            S = self.points.streamwise_derivative
            L, Ra, Rb = self._H_TF_top, self._H_FT_top, S @ self._H_FT_top
            _, ip_a, ix_a = triple_product_operator(L, Ra)
            _, ip_b, ix_b = triple_product_operator(L, Rb)
            n_in = L.shape[0]
            union = sp.csr_matrix((np.ones(ix_a.size), ix_a, ip_a), shape=(n_in, n_in)) + \
                sp.csr_matrix((np.ones(ix_b.size), ix_b, ip_b), shape=(n_in, n_in))
            union.sort_indices()
            qpat = (union.indptr.astype(np.int32), union.indices.astype(np.int32))
            ops["QT_pattern"] = qpat
            ops["QT_a"] = triple_product_operator(L, Ra, qpat)[0]
            ops["QT_b"] = triple_product_operator(L, Rb, qpat)[0]
        elif name == "free":
            ops[name] = _FreePattern(st._indptr, st._indices, st.n_dof, st.free_dofs)
        else:
            raise KeyError(name)
        return ops[name]

    def _aero_stiffness_data(self, loads: FluidLoads) -> Array | None:
        """K_A as data on the structural CSR pattern for a pointwise fluid model, else None."""
        J = loads.jacobians
        if not isinstance(J, PointwiseJacobians):
            return None
        return self._op("KA_slope") @ J.dp_ds  # dp/dw = 0 (pointwise laws)

    def _keep_precond(self, lu) -> None:
        self._precond = lu

    def initial_state(self) -> tuple[Array, Array]:
        """(u0, T0) at t = 0: the initial deflection and the initial temperature field."""
        s = self.settings
        T = self.thermal.initial_state() + s.initial_temperature_rise
        u = np.zeros(self.structure.n_dof)
        if s.initial_deflection:
            x, y = self.structure.mesh.x, self.structure.mesh.y
            shape = np.sin(math.pi * x / self.panel.length)
            if self.panel.kind == "3d":
                shape = shape * np.sin(math.pi * y / self.panel.width)
            u[2::5] = s.initial_deflection * self.panel.thickness * shape
        return u, T

    def relax_inplane(self, u: Array, T: Array, max_iter: int = 30) -> Array:
        """Static equilibrium of every DOF but w, with w held at its value.

        A transient run that starts from a deflected or suddenly heated panel needs an
        initial state whose membrane forces balance (the in-plane waves such an imbalance
        excites are far faster than any step the schemes take): the panel starts at rest
        with the in-plane displacements and rotations in equilibrium with ``w``.
        """
        st = self.structure
        T_s = self.structural_temperature(T)
        T_w = self.wall_temperature(T)
        # every DOF except the free w: the constrained ones too, so the penalty springs
        # carry their static reactions (else the first acceleration is absurd there)
        sub = np.setdiff1d(np.arange(st.n_dof), np.intersect1d(st.free_dofs,
                                                               np.arange(2, st.n_dof, 5)))
        u = np.array(u, dtype=float)
        ref = float(np.linalg.norm(st.thermal_load(T_s)))
        for it in range(max_iter):
            F_I, K = st.force_and_tangent(u, T_s)
            R = (F_I - self.aero_force(self.fluid_loads(u, T_w)))[sub]
            rnorm = float(np.linalg.norm(R))
            if it == 0:
                ref = max(ref, rnorm, 1e-3)
            if rnorm <= 1e-9 * ref:
                return u
            u[sub] -= spla.splu(K[sub][:, sub].tocsc()).solve(R)
        raise EquilibriumError("in-plane equilibrium of the initial state did not converge")

    @property
    def thermal_frozen(self) -> bool:
        """True when nothing heats or cools the panel (no aerodynamic heating, no
        radiation, no external heat flux): the temperature field stays at its initial value
        and the thermal steps are skipped."""
        heating = getattr(self.fluid, "heating", "eckert")
        return (heating == "none" and self.panel.emissivity == 0.0
                and self.settings.external_heat_flux == 0.0)

    # -- fields on the fluid grid -------------------------------------------------------
    def wall_temperature(self, T: Array) -> Array:
        """T_w on the fluid points from the thermal nodal field (Eq. 5.1d)."""
        return self.transfer.H_FT @ T

    def surface_state(self, u: Array, T_w: Array, u_dot: Array | None = None) -> SurfaceState:
        tr = self.transfer
        vel = np.zeros(self.points.n) if u_dot is None else tr.H_FS @ u_dot
        return SurfaceState(tr.H_FS @ u, tr.H_FS_slope @ u, vel, T_w)

    def fluid_loads(self, u: Array, T_w: Array, u_dot: Array | None = None,
                    jacobians: bool = False) -> FluidLoads:
        t0 = time.perf_counter()
        out = self.fluid.evaluate(self.points, self.surface_state(u, T_w, u_dot), self.flow,
                                  jacobians=jacobians)
        self.timer.fluid += time.perf_counter() - t0
        return out

    def structural_temperature(self, T: Array) -> Array:
        """Thermal nodal field -> per-shell-node through-thickness profile (n_nodes, n_levels)."""
        return self.thermal.profile(T)

    # -- aerodynamic operators on the structural DOFs -------------------------------------
    def aero_force(self, loads: FluidLoads) -> Array:
        """F_S = H_SF p + external load (Eqs. 5.1a, 5.27)."""
        return self.transfer.H_SF @ loads.pressure + self._F_ext

    def aero_stiffness(self, loads: FluidLoads) -> sp.csr_matrix | spla.LinearOperator:
        """K_A = dF_S/du = H_SF (dp/dw H_FS + dp/dw_s H_FS_slope) (Eq. 5.34)."""
        tr, J = self.transfer, loads.jacobians
        if isinstance(J, PointwiseJacobians):
            T, indptr, indices = self._op("KA_slope_own")
            n = self.structure.n_dof
            return sp.csr_matrix((T @ J.dp_ds, indices, indptr), shape=(n, n))
        if all(sp.issparse(J[k]) for k in ("dp_dw", "dp_dws")):
            return (tr.H_SF @ (J["dp_dw"] @ tr.H_FS + J["dp_dws"] @ tr.H_FS_slope)).tocsr()
        n = self.structure.n_dof
        return spla.LinearOperator(
            (n, n), dtype=float,
            matvec=lambda x: tr.H_SF @ (J["dp_dw"] @ (tr.H_FS @ x)
                                        + J["dp_dws"] @ (tr.H_FS_slope @ x)))

    def aero_damping(self, loads: FluidLoads) -> sp.csr_matrix:
        """C_A = dF_S/du_dot = H_SF dp/dw_dot H_FS (Eq. 5.34)."""
        tr = self.transfer
        if isinstance(loads.jacobians, PointwiseJacobians):
            T, indptr, indices = self._op("KA_w_own")
            n = self.structure.n_dof
            return sp.csr_matrix((T @ loads.jacobians.dp_dv, indices, indptr), shape=(n, n))
        return sp.csr_matrix(tr.H_SF @ (loads.jacobians["dp_dwdot"] @ tr.H_FS))

    # -- thermal coupling -------------------------------------------------------------------
    def upper_heat_input(self, q_fluid: Array) -> Array:
        """Nodal heat input (W) of the upper surface, ``H_TF (q + q_ext)`` (Eq. 5.1b): the
        fluid heat flux ``q`` on the fluid points plus the uniform external heat flux
        ``settings.external_heat_flux`` (Eq. 6.1d), both W/m^2."""
        return self._H_TF_top @ (q_fluid + self.settings.external_heat_flux)

    def thermal_loads(self, u: Array) -> ThermalLoads:
        """Upper surface: aerodynamic heat flux implicit in the wall temperature (Eq. 5.31a)
        plus the external heat flux (Eq. 6.1d) and radiation to ``T_rad``; lower surface
        insulated."""
        H_FT, H_TF = self._H_FT_top, self._H_TF_top
        cache: list = []

        def flux(T_top: Array) -> tuple[Array, sp.csr_matrix]:
            # nodal heat input Q = H_TF q (Eq. 5.1b) and its derivative, on the thermal pattern;
            # the Newton asks twice at the same T (residual, then Jacobian): cached
            if cache and np.array_equal(cache[0], T_top):
                return cache[1], cache[2]
            loads = self.fluid_loads(u, H_FT @ T_top, jacobians=True)
            J = loads.jacobians
            if isinstance(J, PointwiseJacobians):
                n_top = T_top.size

                def build():  # formed only when the thermal Newton needs its Jacobian
                    a, b = J.tw_coefficients()
                    data = self._op("QT_a") @ a
                    if b is not None:
                        data = data + self._op("QT_b") @ b
                    ip, ix = self._op("QT_pattern")
                    return sp.csr_matrix((data, ix, ip), shape=(n_top, n_top))

                dQ = DeferredMatrix(build, (n_top, n_top))
            else:
                dQ = (H_TF @ sp.csr_matrix(J["dq_dTw"]) @ H_FT).tocsr()
            out = (self.upper_heat_input(loads.heat_flux), dQ)
            cache[:] = [np.array(T_top, copy=True), *out]
            return out

        top = SurfaceCondition(flux=flux, emissivity=self.panel.emissivity, T_rad=self.T_rad,
                               nodal_load=True)
        return ThermalLoads(top=top)

    def thermal_step(self, T: Array, u: Array, dt: float, T_guess: Array | None = None) -> Array:
        t0, fl0 = time.perf_counter(), self.timer.fluid
        f0 = self.thermal.factorizations
        # consecutive steps of the quasi-steady scheme are close: chord iterations with the
        # last step's factorization while they contract the residual by >= 30x, else a
        # fresh Jacobian (the same solution; 15 % less thermal time than a Jacobian and a
        # factorization every step on the Sec. 9.2 benchmark)
        res = self.thermal.step(T, dt, self.thermal_loads(u), alpha=self.settings.thermal_alpha,
                                T_guess=T_guess, jacobian="modified", contraction=0.03)
        self.timer.factorizations += self.thermal.factorizations - f0
        # the implicit wall flux calls the fluid model: count that time as fluid only
        self.timer.thermal += time.perf_counter() - t0 - (self.timer.fluid - fl0)
        if not res.converged:
            raise EquilibriumError(f"thermal Newton did not converge (residual "
                                   f"{res.residual_norm:.3g} W)")
        return res.T

    # -- aeroelastic equilibrium ---------------------------------------------------------------
    def equilibrium(self, u: Array, T: Array, guess: Array | None = None
                    ) -> tuple[Array, int]:
        """Static aeroelastic equilibrium ``F_I(u, T) = F_S(u, 0, T)`` (Eq. 5.31b).

        Newton-Raphson with the aerodynamic Jacobian (Eq. 5.42) from ``u``. Full Newton
        steps are taken (a residual-norm line search stalls on the membrane stiffening of
        thin panels); when Newton fails, the load -- the aerodynamic force and the
        temperature rise from the initial state -- is applied in increments from ``u``.

        ``guess`` (optional) is a predicted solution, e.g. extrapolated from the previous
        time steps: Newton starts there first, and its result is kept only when the
        correction is smaller than the prediction's distance from ``u`` (so a prediction
        past a limit point cannot carry the solution to another equilibrium branch); else
        the solution starts from ``u`` as without a guess.

        Returns
        -------
        u, iterations
        """
        if guess is not None:
            precond = self._precond
            try:
                x, it = self._newton(guess, T, 1.0)
                if np.linalg.norm(x - guess) <= np.linalg.norm(guess - u):
                    return x, it
            except EquilibriumError:
                pass
            # a failed prediction leaves no trace: the solution from u proceeds exactly as
            # without one (same preconditioner, hence the same Newton path)
            self._precond = precond
        try:
            return self._newton(u, T, 1.0)
        except EquilibriumError:
            pass
        T0 = self.thermal.initial_state()
        total = 0
        for steps in (4, 16):
            x = np.array(u, copy=True)
            try:
                for k in range(1, steps + 1):
                    lam = k / steps
                    x, it = self._newton(x, T0 + lam * (T - T0), lam)
                    total += it
                return x, total
            except EquilibriumError:
                continue
        return self._newton(u, T, 1.0)  # raises with the diagnostic of the full problem

    def _newton(self, u: Array, T: Array, load: float) -> tuple[Array, int]:
        """Newton iterations on ``F_I(u, T) - load * F_S(u, T) = 0`` (free DOFs; the
        constrained DOFs keep their values)."""
        s = self.settings
        st = self.structure
        T_s = self.structural_temperature(T)
        T_w = self.wall_temperature(T)
        free = st.free_dofs

        def residual(x: Array):
            loads = self.fluid_loads(x, T_w, jacobians=True)
            t0 = time.perf_counter()
            F_I, K = st.force_and_tangent(x, T_s)
            self.timer.structural += time.perf_counter() - t0
            # the LSA at the converged state reuses the tangent and the fluid loads
            self._last_state = (x, T, K, loads, self.flow, self.fluid)
            return F_I - load * self.aero_force(loads), K, loads

        R, K, loads = residual(u)
        ref = max(float(np.linalg.norm(st.thermal_load(T_s)[free])),
                  float(np.linalg.norm((self.transfer.H_SF @ loads.pressure)[free])),
                  float(np.linalg.norm(self._F_ext[free])), 1e-3)
        rnorm = float(np.linalg.norm(R[free]))
        for it in range(s.newton_max_iter):
            if rnorm <= s.newton_rtol * ref:
                return u, it
            t0 = time.perf_counter()
            du = np.zeros_like(u)
            KA_data = self._aero_stiffness_data(loads)
            if KA_data is not None:
                # pointwise fluid: (K - load K_A) on the structural pattern, data only
                du[free] = self._solve_free(K.data - load * KA_data, -R[free])
            else:
                KA = self.aero_stiffness(loads)
                KA = load * KA if sp.issparse(KA) else _scaled(KA, load)
                du[free] = self._solve(K, KA, -R[free])
            self.timer.structural += time.perf_counter() - t0
            u = u + du
            R, K, loads = residual(u)
            rnorm = float(np.linalg.norm(R[free]))
            if not np.isfinite(rnorm):
                break
        raise EquilibriumError(
            f"aeroelastic equilibrium did not converge in {s.newton_max_iter} Newton "
            f"iterations (residual {rnorm:.3g} N vs scale {ref:.3g} N)")

    def _gmres_precond(self, matvec, b: Array) -> Array | None:
        """GMRES preconditioned by the kept factor (:func:`hypate.solvers.numerics.sparse.gmres`, at most
        20 iterations); None when the factor is missing or too weak."""
        if self._precond is None or self._precond.shape[0] != b.size:
            return None
        # (a hand-rolled GMRES: scipy's costs 0.1 ms per iteration more in Python overhead,
        # a third of each iteration here)
        x, _, _ = gmres(matvec, self._precond.solve, b, rtol=1e-11, max_iter=20)
        # an inexact Newton step is enough: accept 1e-6 relative (GMRES may stagnate near
        # 1e-8 on these badly scaled shell systems)
        if np.linalg.norm(matvec(x) - b) <= 1e-6 * np.linalg.norm(b):
            return x
        return None

    def _solve_free(self, data: Array, b: Array) -> Array:
        """:meth:`_solve` for ``K - K_A`` given as data on the structural pattern (pointwise
        fluid): the free block by index maps, the factor by :meth:`_FreePattern.factor`."""
        fp = self._op("free")
        block = data[fp.sel]
        A = sp.csr_matrix((block, fp.indices, fp.indptr), shape=(fp.n, fp.n))
        x = self._gmres_precond(A.__matmul__, b)
        if x is not None:
            return x
        self.timer.factorizations += 1
        self._precond = fp.factor(block)
        return self._precond.solve(b)

    def _solve(self, K: sp.csr_matrix, KA, b: Array) -> Array:
        """Solve ``(K - K_A)_ff x = b`` on the free DOFs.

        GMRES preconditioned by the last factorization of a nearby Jacobian (the LSA's
        factor of the previous step, Eqs. 5.44-5.45 with a better preconditioner than K
        alone); when GMRES needs many iterations the current matrix is factorized (sparse
        LU) and becomes the preconditioner. A low-rank/operator K_A (a ROM) is applied
        matrix-free.
        """
        free = self.structure.free_dofs
        Kff = K[free][:, free]
        if sp.issparse(KA):
            A = (Kff - KA[free][:, free]).tocsc()
            matvec = A.__matmul__
        else:
            A = Kff.tocsc()
            n_all = K.shape[0]

            def matvec(x: Array) -> Array:
                full = np.zeros(n_all)
                full[free] = x
                return Kff @ x - (KA @ full)[free]
        x = self._gmres_precond(matvec, b)
        if x is not None:
            return x
        self.timer.factorizations += 1
        self._precond = spla.splu(A)
        if sp.issparse(KA):
            return self._precond.solve(b)
        n = b.size
        x, info = spla.gmres(spla.LinearOperator((n, n), matvec=matvec, dtype=float), b,
                             M=spla.LinearOperator((n, n), matvec=self._precond.solve,
                                                   dtype=float),
                             rtol=1e-11, atol=0.0, restart=80, maxiter=3)
        if info != 0:
            raise EquilibriumError("GMRES for the aeroelastic Newton step did not converge")
        return x

    # -- stability -----------------------------------------------------------------------------
    def stability(self, u: Array, T: Array, method: str = "gep") -> StabilityResult:
        """LSA about the state (u, T): GEP (Eq. 5.35) or PEP with C - C_A (Eq. 5.33)."""
        t0, fl0 = time.perf_counter(), self.timer.fluid
        st = self.structure
        T_s = self.structural_temperature(T)
        last = self._last_state
        if (last is not None and last[4] is self.flow and last[5] is self.fluid
                and np.array_equal(last[0], u) and np.array_equal(last[1], T)):
            K, loads = last[2], last[3]  # the Newton's last residual is at this state
        else:
            loads = self.fluid_loads(u, self.wall_temperature(T), jacobians=True)
            K = st.tangent(u, T_s)
        M = st.mass(T_s)
        KA_data = self._aero_stiffness_data(loads) if method == "gep" else None
        if KA_data is not None:
            res = self._gep_pointwise(K, M, KA_data)
            self.timer.stability += time.perf_counter() - t0 - (self.timer.fluid - fl0)
            self.timer.factorizations += 1
            return res
        KA = self.aero_stiffness(loads)
        free = st.free_dofs
        if not sp.issparse(KA):
            KA = sp.csr_matrix(KA @ np.eye(st.n_dof))  # ROM operator: small dense product
        if method == "pep":
            res = pep(K, M, st.damping(T_s), KA, self.aero_damping(loads),
                      count=self.settings.lsa_modes, free=free)
        else:
            res = gep(K, M, KA, count=self.settings.lsa_modes, free=free,
                      on_factor=self._keep_precond)
        self.timer.stability += time.perf_counter() - t0 - (self.timer.fluid - fl0)
        self.timer.factorizations += 1
        return res

    def _gep_pointwise(self, K: sp.csr_matrix, M: sp.csr_matrix, KA_data: Array
                       ) -> StabilityResult:
        """:func:`hypate.solvers.coupling.stability.gep` (direct solver, default shift) on the free block
        built by index maps; its factor becomes the Newton preconditioner."""
        fp = self._op("free")
        Kb, Mb = K.data[fp.sel], M.data[fp.sel]
        Mff = sp.csr_matrix((Mb, fp.indices, fp.indptr), shape=(fp.n, fp.n))
        scale = float(np.mean(np.abs(Kb[fp.diag]) / np.maximum(np.abs(Mb[fp.diag]), 1e-300)))
        sigma = -1e-9 * scale  # as gep's default shift
        lu = fp.factor((Kb - sigma * Mb) - KA_data[fp.sel])
        self._keep_precond(lu)
        # the mass couples like DOFs only: 80 % of the shell pattern's entries are zero, and
        # each Arnoldi step multiplies by M (3.5x faster without them)
        Mff = Mff.copy()  # (it shares the index arrays of the free pattern)
        Mff.eliminate_zeros()
        k = self.settings.lsa_modes

        def keep(vectors):  # the next LSA starts from these modes (nearby state)
            self._lsa_start = start_vector(vectors)

        # started from the last step's modes with ARPACK's default 20 Arnoldi vectors, the
        # eigenvalues converge in the first Arnoldi pass: 21 shifted solves per LSA instead
        # of 27 (random start, 2k + 2 vectors), the same eigenvalues to 1e-13 (measured on
        # the Sec. 9.2 benchmark)
        return shift_invert_gep(lu.solve, Mff, sigma, count=k, rng=0,
                                v0=self._lsa_start, on_vectors=keep)


def _scaled(op: spla.LinearOperator, factor: float) -> spla.LinearOperator:
    return spla.LinearOperator(op.shape, matvec=lambda x: factor * (op @ x), dtype=float)


def extrapolate(history: list[Array]) -> Array:
    """Polynomial extrapolation to the next of equally spaced states, ``history`` newest
    first: ``3 x_n - 3 x_(n-1) + x_(n-2)`` (quadratic) from three states, ``2 x_n - x_(n-1)``
    from two, ``x_n`` from one. A smooth history ``x(t)`` is predicted to O(dt^3)."""
    if len(history) >= 3:
        return 3.0 * history[0] - 3.0 * history[1] + history[2]
    if len(history) == 2:
        return 2.0 * history[0] - history[1]
    return np.array(history[0], copy=True)


def run_tc(model: PanelModel, progress=None) -> Response:
    """Tightly coupled quasi-steady scheme (Sec. 5.4.3) with LSA each step.

    Parameters
    ----------
    model : PanelModel
    progress : callable(step, n_steps), optional
        Called after every step.

    Returns
    -------
    Response
        Histories up to the end or to the instability (``instability_time``,
        ``instability_type``); a solver failure ends the run with ``status = "failed"``
        and the reason in ``message`` (never an exception).
    """
    # one BLAS thread: every dense operation of a step is small, and on a busy machine
    # OpenBLAS's second thread spins or waits for a core (measured: the ARPACK eigenvector
    # extraction takes 50 ms instead of 1 ms, the whole run 30-50 % longer)
    with single_threaded_blas():
        return _run_tc(model, progress)


def _run_tc(model: PanelModel, progress) -> Response:
    s = model.settings
    dt, n_steps = s.time_step, s.n_steps
    resp = Response.start(model, scheme="tc")
    u, T = model.initial_state()
    unstable_run = 0
    first_unstable: tuple[float, str] | None = None
    t_start = time.perf_counter()
    try:
        u, _ = model.equilibrium(u, T)
        lsa = model.stability(u, T)
        resp.record(0.0, u, T, model, lsa)
        # converged states of the previous steps, newest first: the Newton predictors
        T_hist: list[Array] = []
        u_hist: list[Array] = []
        for n in range(1, n_steps + 1):
            t = n * dt
            T_new, u_new = T, u
            for k in range(s.passes):
                T_prev, u_prev = T_new, u_new
                if not model.thermal_frozen:
                    # the thermal Newton starts from the extrapolation of the last steps (same
                    # solution, about one Newton iteration fewer per step)
                    guess = T_new if (k > 0 or not T_hist) else extrapolate([T, *T_hist])
                    T_new = model.thermal_step(T, u_new, dt, T_guess=guess)
                # likewise the aeroelastic Newton (the same equilibrium to its tolerance: 1.3
                # instead of 2.4 iterations per step on the Sec. 9.2 benchmark)
                u_guess = extrapolate([u, *u_hist]) if (k == 0 and u_hist) else None
                u_new, _ = model.equilibrium(u_new, T_new, guess=u_guess)
                dT = np.max(np.abs(T_new - T_prev)) / max(np.max(np.abs(T_new - T)), 1e-12)
                du = np.max(np.abs(u_new - u_prev)) / max(np.max(np.abs(u_new)), 1e-12)
                if dT <= s.pass_tol and du <= s.pass_tol:
                    break
            T_hist, u_hist = [T, *T_hist[:1]], [u, *u_hist[:1]]
            T, u = T_new, u_new
            lsa = model.stability(u, T) if n % s.lsa_every == 0 else None
            resp.record(t, u, T, model, lsa)
            if progress is not None:
                progress(n, n_steps)
            if lsa is not None and lsa.unstable:
                unstable_run += 1
                if first_unstable is None:
                    first_unstable = (t, lsa.status)
                if unstable_run >= s.unstable_steps:
                    resp.finish("unstable", f"{lsa.status} detected by the LSA at "
                                f"t = {first_unstable[0]:g} s", first_unstable)
                    break
            elif lsa is not None:
                unstable_run, first_unstable = 0, None
        else:
            resp.finish("completed", "", None)
    except EquilibriumError as exc:
        if not resp.times:
            resp.finish("failed", f"no equilibrium at t = 0: {exc}", None)
        else:
            # the quasi-steady equilibrium ceased to exist during the step: a limit point of
            # the static aeroelastic problem, i.e. a snap-through (divergence-type instability)
            t_fail = resp.times[-1] + dt
            resp.finish("unstable", f"static aeroelastic equilibrium lost at t = {t_fail:g} s "
                        f"(limit point, snap-through): {exc}",
                        first_unstable or (t_fail, "divergence"))
    resp.wall_seconds = time.perf_counter() - t_start
    resp.timing = model.timer.as_dict()
    return resp


def _explicit_thermal_loads(model: PanelModel, q_fluid: Array) -> ThermalLoads:
    """Thermal loads with a given (estimated) fluid heat flux plus the external heat flux
    (Eq. 6.1d) and radiation (S1/S2)."""
    top = SurfaceCondition(flux=model.upper_heat_input(q_fluid),
                           emissivity=model.panel.emissivity, T_rad=model.T_rad, nodal_load=True)
    return ThermalLoads(top=top)


def run_lc(model: PanelModel, scheme: str = "s2", rho_bar: float = 1.0, record_every: int = 1,
           progress=None, stop_on_snap: bool = True,
           record_energy: bool = False, ramp_time: float = 0.0) -> Response:
    """Loosely coupled transient schemes S1 and S2 (Sec. 5.3.1), time step ``settings.time_step``.

    Both: thermal step with the extrapolated heat flux ``1.5 q^n - 0.5 q^(n-1)`` (Eq. 5.2).
    S1: structure with the extrapolated pressure ``2 p^n - p^(n-1)`` (Eq. 5.3), then the fluid
    at the new displacement (Eq. 5.4). S2: fluid at the extrapolated displacement
    ``u^n + dt (1.5 v^n - 0.5 v^(n-1))`` (Eq. 5.5), then the structure with that pressure
    (Eq. 5.6). Start: Eq. (5.7). Generalized-alpha structure, Crank-Nicolson thermal.
    The fluid is handed displacements only (Eq. 5.8) and forms the wall velocity of the
    piston-theory term from them by the three-point backward difference of Eq. (2.28).

    ``ramp_time > 0`` gives a smooth start: the fluid pressure and heat flux are multiplied
    by the C^3 smoothstep ``s(t / ramp_time)`` (``s = 35x^4 - 84x^5 + 70x^6 - 20x^7``, 0 at
    t = 0, 1 from ``ramp_time`` on) -- a flow switched on over ``ramp_time`` instead of
    impulsively. The default 0 is the impulsive start of the benchmarks; the smooth start is
    for convergence studies, where the impulsive start's high-frequency transient (modes no
    practical step resolves) masks the schemes' order. The stored pressure and heat flux are
    the ramped ones.

    The run ends at ``settings.duration``; with ``stop_on_snap`` it ends once a snap-through
    is over (the centre deflection has reversed sign and passed its pre-snap magnitude).

    With ``record_energy`` the artificial energy of the fluid-structure interface of every
    step (Sec. 5.3.3) is stored in ``Response.artificial_energy`` (J, entry ``n-1`` for the
    step ``t^(n-1) -> t^n``; NaN for the start step, Eq. 5.7):
    ``dE = dE_S + dE_F`` (Eq. 5.21), with the work on the structure
    ``dE_S = 1/2 (F^(n+1,E) + F^(n,E))^T (u^(n+1) - u^n)`` (Eq. 5.19) and the work on the fluid
    ``dE_F = -1/2 (F^(n+1) + F^n)^T (u^(n+1,E) - u^(n,E))`` (Eq. 5.20), ``F = H_SF p``;
    superscript E marks the estimated values each scheme hands over (S1: ``p^E`` by Eq. 5.3,
    ``u^E = u``; S2: ``p^E = p``, ``u^E`` by Eq. 5.5). Per step it is O(dt^3) for S1 (Eq. 5.23)
    and O(dt^4) for S2 (Eq. 5.24).
    """

    if scheme not in ("s1", "s2"):
        raise InputError("simulation.scheme", "loosely coupled schemes are 's1' and 's2'")
    s = model.settings
    dt, n_steps = s.time_step, s.n_steps
    st, tr = model.structure, model.transfer
    resp = Response.start(model, scheme=scheme)
    u0, T = model.initial_state()
    u0 = model.relax_inplane(u0, T)
    T_s = model.structural_temperature(T)
    T_w = model.wall_temperature(T)
    if not (ramp_time >= 0.0 and math.isfinite(ramp_time)):
        raise InputError("ramp_time", "must be >= 0 (s)")

    def fluid(t: float, u: Array, T_w: Array, u_dot: Array | None = None) -> FluidLoads:
        """The fluid solution at t (ramped on over ``ramp_time``)."""
        loads = model.fluid_loads(u, T_w, u_dot=u_dot)
        k = _smoothstep(t / ramp_time) if ramp_time > 0.0 else 1.0
        return loads if k == 1.0 else FluidLoads(k * loads.pressure, k * loads.heat_flux)

    def record(t: float, u: Array, T: Array, u_dot: Array | None = None) -> None:
        resp.record(t, u, T, model, None, u_dot=u_dot)
        k = _smoothstep(t / ramp_time) if ramp_time > 0.0 else 1.0
        if k != 1.0 and resp.keep_fields:
            resp.pressure[-1] *= k
            resp.heat_flux[-1] *= k

    loads0 = fluid(0.0, u0, T_w)
    F0 = model.aero_force(loads0)
    stepper = AlphaStepper(st, dt, rho_bar=rho_bar, u0=u0, T0=T_s, F0=F0)
    record(0.0, stepper.u, T)
    center = 5 * st.mesh.center + 2
    t_start = time.perf_counter()
    # start procedure, Eq. (5.7): u^1, v^1 from the initial acceleration -- on the free
    # transverse DOFs; the in-plane, rotational and penalty-constrained DOFs are far
    # stiffer than any explicit step resolves, so they are relaxed to equilibrium at t^1
    w_free = np.intersect1d(st.free_dofs, np.arange(2, st.n_dof, 5))
    u1, v1 = stepper.u.copy(), stepper.v.copy()
    u1[w_free] += dt * stepper.v[w_free] + 0.5 * dt * dt * stepper.a[w_free]
    v1[w_free] += dt * stepper.a[w_free]
    p_hist = [loads0.pressure, None]
    q_hist = [loads0.heat_flux, loads0.heat_flux]
    v_prev = stepper.v.copy()
    # displacements handed to the fluid at the last two step ends, u^(n,E) and u^(n-1,E)
    # (Eq. 5.8): the fluid forms its wall velocity from them by Eq. (2.28)
    uE_hist = [u0, u0]
    peak = 0.0
    # interface histories of the energy balance (Sec. 5.3.3): estimated and actual pressure
    # and the estimated displacement at the previous step end
    pE_prev = p_act_prev = uE_prev = None
    try:
        for n in range(1, n_steps + 1):
            t = n * dt
            # -- thermal step with the extrapolated heat flux (Eq. 5.2)
            if not model.thermal_frozen:
                q_est = 1.5 * q_hist[0] - 0.5 * q_hist[1]
                t0 = time.perf_counter()
                res = model.thermal.step(T, dt, _explicit_thermal_loads(model, q_est),
                                         alpha=s.thermal_alpha)
                model.timer.thermal += time.perf_counter() - t0
                if not res.converged:
                    raise EquilibriumError("thermal Newton did not converge")
                T = res.T
                T_s = model.structural_temperature(T)
                T_w = model.wall_temperature(T)
            if n == 1:
                # Eq. (5.7): the first step is taken by the start procedure
                u1 = model.relax_inplane(u1, T)
                loads = fluid(t, u1, T_w, u_dot=v1)
                stepper.u, stepper.v = u1, v1
                stepper.FI = st.internal_force(u1, T_s)
                stepper.F = model.aero_force(loads)
                stepper.a = st.solver.factor(stepper.M).solve(
                    stepper.F - stepper.FI - (stepper.C @ v1 if stepper.has_damping else 0.0))
                p_hist = [loads.pressure, p_hist[0]]
                pE_prev = p_act_prev = loads.pressure
                uE_prev = u1
                uE_hist = [u1, uE_hist[0]]
                if record_energy:
                    resp.artificial_energy.append(float("nan"))
            elif scheme == "s1":
                p_est = 2.0 * p_hist[0] - p_hist[1]  # Eq. (5.3)
                u_old = stepper.u
                t0 = time.perf_counter()
                u, v, _ = stepper.step(tr.H_SF @ p_est + model._F_ext, T_s)
                model.timer.structural += time.perf_counter() - t0
                # Eq. (5.4): u^(n+1,E) = u^(n+1); wall velocity by Eq. (2.28)
                loads = fluid(t, u, T_w, u_dot=_bdf2_velocity(u, uE_hist, dt))
                uE_hist = [u, uE_hist[0]]
                p_hist = [loads.pressure, p_hist[0]]
                if record_energy:  # Eqs. (5.19)-(5.21) with u^E = u
                    du = tr.H_SF.T @ (u - u_old)
                    resp.artificial_energy.append(float(
                        0.5 * (p_est + pE_prev) @ du - 0.5 * (loads.pressure + p_act_prev) @ du))
                pE_prev, p_act_prev = p_est, loads.pressure
            else:
                u_est = stepper.u + dt * (1.5 * stepper.v - 0.5 * v_prev)  # Eq. (5.5)
                # the fluid's wall velocity at t^(n+1) from the estimated displacements,
                # Eq. (2.28) (not 1.5 v^n - 0.5 v^(n-1): that is v at t^(n+1/2), an O(dt)
                # error in the piston-theory velocity term)
                loads = fluid(t, u_est, T_w, u_dot=_bdf2_velocity(u_est, uE_hist, dt))
                uE_hist = [u_est, uE_hist[0]]
                v_prev = stepper.v.copy()
                u_old = stepper.u
                t0 = time.perf_counter()
                stepper.step(model.aero_force(loads), T_s)  # Eq. (5.6)
                model.timer.structural += time.perf_counter() - t0
                p_hist = [loads.pressure, p_hist[0]]
                if record_energy:  # Eqs. (5.19)-(5.21) with p^E = p
                    p_mid = 0.5 * (loads.pressure + p_act_prev)
                    resp.artificial_energy.append(float(
                        p_mid @ (tr.H_SF.T @ ((stepper.u - u_old) - (u_est - uE_prev)))))
                pE_prev, p_act_prev, uE_prev = loads.pressure, loads.pressure, u_est
            if n == 1:
                v_prev = stepper.v.copy() if scheme == "s1" else v_prev
            q_hist = [loads.heat_flux, q_hist[0]]
            if not np.all(np.isfinite(stepper.u)):
                raise EquilibriumError("the transient response diverged (non-finite state)")
            if n % record_every == 0 or n == n_steps:
                record(t, stepper.u, T, u_dot=stepper.v)
            if progress is not None:
                progress(n, n_steps)
            w = float(stepper.u[center])
            if stop_on_snap:
                if abs(w) > abs(peak) and (peak == 0.0 or np.sign(w) == np.sign(peak)):
                    peak = w
                elif (abs(peak) > 0.25 * model.panel.thickness and np.sign(w) != np.sign(peak)
                      and abs(w) > abs(peak)):
                    onset = snap_onset(np.asarray(resp.times), np.asarray(resp.center_deflection))
                    resp.finish("unstable", "snap-through", (onset, "divergence"))
                    break
        else:
            resp.finish("completed", "", None)
    except EquilibriumError as exc:
        resp.finish("failed", str(exc), None)
    resp.wall_seconds = time.perf_counter() - t_start
    resp.timing = model.timer.as_dict()
    return resp


def _smoothstep(x: float) -> float:
    """C^3 smoothstep ``35x^4 - 84x^5 + 70x^6 - 20x^7`` on [0, 1], 0 below and 1 above."""
    x = min(max(float(x), 0.0), 1.0)
    return x ** 4 * (35.0 - 84.0 * x + 70.0 * x * x - 20.0 * x ** 3)


def _bdf2_velocity(u_new: Array, u_hist: list[Array], dt: float) -> Array:
    """Wall velocity the fluid forms from the displacements it is handed, Eq. (2.28):
    ``(3 u^(n+1,E) - 4 u^(n,E) + u^(n-1,E)) / (2 dt)``, second order at t^(n+1)."""
    return (3.0 * u_new - 4.0 * u_hist[0] + u_hist[1]) / (2.0 * dt)


def snap_onset(times: Array, w: Array) -> float:
    """Onset of a snap-through in a deflection history: the last time the deflection still
    moved away from zero on the pre-snap side (the turning point before the reversal)."""
    sign0 = np.sign(w[np.argmax(np.abs(w[: max(2, np.argmax(np.sign(w) != np.sign(w[-1])))]))])
    pre = np.flatnonzero(np.sign(w) == sign0)
    if pre.size == 0:
        return float(times[0])
    last = pre[-1]
    k = int(np.argmax(np.abs(w[: last + 1])))
    return float(times[k])


def settings_from_config(sim) -> CouplingSettings:
    """:class:`CouplingSettings` from a validated ``[simulation]`` table."""
    return CouplingSettings(time_step=sim.time_step, duration=sim.duration,
                            radiation_temperature=sim.radiation_temperature,
                            external_pressure=sim.external_pressure,
                            external_heat_flux=sim.external_heat_flux, lsa_modes=sim.lsa_modes,
                            unstable_steps=sim.unstable_steps, passes=sim.passes,
                            fluid_density=sim.fluid_density)


def simulate(panel: PanelSpec, flow: FlowCondition, sim, progress=None,
             keep_fields: bool = True) -> Response:
    """Run a case: ``sim`` is a validated ``[simulation]`` table (scheme, aero, heating...).

    The entry point of ``hypate simulate`` and of the scaling problem's evaluations.
    """

    fluid = make_fluid_model(sim.aero, sim.heating, sim.boundary_layer)
    settings = replace(settings_from_config(sim), keep_fields=keep_fields)
    model = PanelModel(panel, flow, fluid, settings)
    if sim.scheme == "tc":
        return run_tc(model, progress=progress)
    every = max(1, int(round(0.01 / sim.time_step)))  # record about every 10 ms
    return run_lc(model, sim.scheme, rho_bar=sim.rho_bar, record_every=every, progress=progress)
