"""Layer-wise heat conduction (HTSH element) with Crank-Nicolson time stepping, Ch. 4.

The panel is meshed with 8-node hexahedra stacked through the thickness (one per thermal
sub-layer, :mod:`hypate.solvers.thermal.mesh`), so the through-thickness temperature is piecewise
linear as the layer-wise thermal lamination theory requires (Sec. 4.2). The semi-discrete
equations are Eq. (4.25)/(4.27),

    C_T(T) dT/dt + K_T(T) T = Q_T(T),

with the capacity matrix C_T (Eq. 4.23b), the conductivity matrix K_T (Eq. 4.23a, the
orthotropic temperature-dependent tensor of Eq. 4.2 rotated by the layer angle) and the
boundary load Q_T (Eq. 4.23c/4.24: prescribed flux, convection, radiation), integrated with
2 x 2 x 2 (volume) and 2 x 2 (surface) Gauss points (reference kernels in
:mod:`hypate.solvers.thermal.element`). Prescribed temperatures use the penalty
method (Eqs. 4.26-4.27). Each step solves the Crank-Nicolson residual (Eq. 4.28) by Newton-
Raphson with line search using the exact Jacobian (Eqs. 4.29-4.32);
:mod:`hypate.solvers.thermal.march` marches the steps.

Sign convention: a surface heat flux ``q`` is positive *into* the panel (heating); radiation
``eps sigma (T^4 - T_rad^4)`` and convection ``h (T - T_ambient)`` leave the surface.

Linear algebra: the global matrices share one CSR pattern (assembled with precomputed
scatter maps, no Python loop over elements). Linear systems are solved with LAPACK banded
factorizations (:mod:`hypate.solvers.numerics.banded`) in a structured ordering
(:func:`banded_position`, through-thickness fastest): Cholesky when the
Jacobian is symmetric (constant conductivity), LU otherwise. A factorization is reused as
long as the Jacobian is bit-for-bit unchanged (constant properties without radiation: one
factorization for the whole run), or, with ``jacobian="modified"``, as long as the modified
Newton iteration contracts.

The model is built in layers, one responsibility each: :mod:`.assembly` (mesh, pattern, volume
terms), :mod:`.boundary` (fluxes, convection, radiation, penalty), :mod:`.newton` (residual,
Jacobian, factorizations, Newton steps); :class:`ThermalModel` adds the march and the outputs.
Boundary conditions are :mod:`.loads`.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np
from hypate.solvers.thermal.loads import ThermalLoads
from hypate.solvers.thermal.march import ThermalHistory, simulate
from hypate.solvers.thermal.newton import ThermalNewton
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]


class ThermalModel(ThermalNewton):
    """HTSH thermal finite-element model of one panel (Ch. 4), built once per panel.

    Precomputes the hexahedron mesh, the CSR sparsity pattern with scatter maps, the
    quadrature data and, for constant properties, the constant matrices.

    Parameters
    ----------
    panel : PanelSpec
        Layers (bottom to top, each with ``sublayers`` hexahedra through it), planform and
        the shell mesh whose in-plane node grid the thermal mesh shares.
    rtol : float
        Newton convergence: max-norm of the residual on unconstrained rows relative to the
        largest of its terms (capacity, conduction, boundary loads).
    xtol : float
        Newton convergence: max-norm of the temperature increment relative to
        ``max(1 K, max |T|)``.
    max_iterations : int
        Newton iterations per solve before giving up (a ``RuntimeWarning``).
    jacobian : {"full", "modified"}
        "full": exact Jacobian each iteration (a factorization is reused when the Jacobian
        is bit-for-bit unchanged, and for chord steps, see ``chord_threshold``).
        "modified": keep the last factorization while the iteration
        contracts the residual by at least ``contraction`` per iteration; refactor otherwise.
    chord_threshold : float
        Once the relative residual is below this, later iterations of the same solve reuse
        the step's last factorization (chord steps) while they contract; 0 disables.
    contraction : float
        Required residual-norm reduction per iteration with a reused (modified-Newton or
        chord) factorization; slower contraction refreshes the Jacobian.
    max_step_fraction : float
        A Newton update changes no temperature by more than this fraction of
        ``max |T|`` (guards the radiation T^4 against wild first steps).
    blas_threads : int or None
        BLAS threads during solves (default 1: the element kernels and banded
        factorizations are small, and multithreaded OpenBLAS on a loaded 2-core machine was
        measured 1000x slower); None leaves the BLAS setting alone.

    Attributes
    ----------
    mesh : HexMesh
        The hexahedron mesh (numbering in :mod:`hypate.solvers.thermal.mesh`).
    n_nodes, n_inplane, n_levels : int
        Thermal nodes (= n_levels * n_inplane), in-plane grid points, node levels.
    surface_mass : csr_matrix of shape (n_inplane, n_inplane)
        Surface mass matrix ``int N_i N_j dA`` (m^2): nodal flux -> consistent nodal load.
    area_weights : ndarray of shape (n_inplane,)
        ``int N_i dA`` (m^2); ``volume_weights`` (n_nodes,): ``int N_i dV`` (m^3).
    factorizations : int
        Running count of Jacobian factorizations (for cost accounting).
    residual_evaluations : int
        Running count of residual evaluations (Eq. 4.28, with or without the Jacobian).
    constant_properties : bool
        All layers have temperature-independent k and rho c_p (matrices built once).

    Notes
    -----
    Node numbering (thermal node id ``k * n_inplane + inplane_id``) is described in
    :mod:`hypate.solvers.thermal.mesh`. Units: K, m, s, W.
    """

    def simulate(self, T0: ArrayLike | None, dt: float, n_steps: int,
                 loads: ThermalLoads | Callable[[float], ThermalLoads], *,
                 alpha: float = 0.5, keep_nodal: bool = False,
                 damped_start: int = 0) -> ThermalHistory:
        """March ``n_steps`` Crank-Nicolson steps from ``T0`` (default: uniform initial).

        :func:`hypate.solvers.thermal.march.simulate` on this model (the parameters and
        the Rannacher start-up ``damped_start`` are described there).

        Returns
        -------
        ThermalHistory
        """
        return simulate(self, T0, dt, n_steps, loads, alpha=alpha, keep_nodal=keep_nodal,
                        damped_start=damped_start)

    # ------------------------------------------------------------------------------------
    # Outputs
    # ------------------------------------------------------------------------------------
    def initial_state(self) -> Array:
        """Uniform initial temperature field, shape (n_nodes,) (K)."""
        return np.full(self.n_nodes, float(self.panel.initial_temperature))

    @property
    def levels(self) -> Array:
        """z of the node levels, bottom to top (m), shape (n_levels,)."""
        return self.mesh.z

    def wall_temperature(self, T: ArrayLike) -> Array:
        """Upper-surface (wall) nodal temperatures, shape (..., n_inplane) (K)."""
        T = np.asarray(T, float)
        return T[..., self.mesh.top_nodes]

    def bottom_temperature(self, T: ArrayLike) -> Array:
        """Lower-surface nodal temperatures, shape (..., n_inplane) (K)."""
        T = np.asarray(T, float)
        return T[..., self.mesh.bottom_nodes]

    def profile(self, T: ArrayLike) -> Array:
        """Through-thickness temperatures per shell-grid node, shape (n_inplane, n_levels).

        Column k is the level ``levels[k]``; between levels the temperature is linear
        (layer-wise lamination theory, Sec. 4.2).
        """
        T = np.asarray(T, float)
        return T.reshape(self.n_levels, self.n_inplane).T

    def mean_temperature(self, T: ArrayLike) -> Array | float:
        """Volume-mean temperature ``int T dV / V`` (K); T of shape (..., n_nodes)."""
        out = np.asarray(T, float) @ self.volume_weights / self.volume
        return float(out) if np.ndim(out) == 0 else out

    def surface_mean(self, T: ArrayLike, surface: str = "top") -> Array | float:
        """Area-averaged temperature of the upper or lower surface (K)."""
        off = self._surface_offset(surface)
        Ts = np.asarray(T, float)[..., off:off + self.n_inplane]
        out = Ts @ self.area_weights / self.area
        return float(out) if np.ndim(out) == 0 else out

    def failed_area_fraction(self, T: ArrayLike, threshold: float, samples: int = 8) -> float:
        """Fraction of the upper surface where the temperature exceeds ``threshold``.

        The failed region of Sec. 8.3.4 (T_max = 850 K there). Each surface cell is sampled
        at ``samples x samples`` midpoints of the bilinear temperature field.

        Returns
        -------
        float in [0, 1]
        """
        Tw = self.wall_temperature(self.check_temperature(T))
        u = (np.arange(samples) + 0.5) / samples
        U: Array  # 2-D from meshgrid, raveled to 1-D below
        V: Array
        U, V = np.meshgrid(u, u)
        U, V = U.ravel(), V.ravel()
        Ns = np.column_stack([(1 - U) * (1 - V), U * (1 - V), (1 - U) * V, U * V])
        Ts = Tw[self.mesh.faces] @ Ns.T  # (n_cells, samples^2)
        cell_area = 4.0 * self._detJ2
        failed = (Ts > threshold).mean(axis=1) @ cell_area
        return float(failed / cell_area.sum())

    def stored_energy(self, T: ArrayLike, T_ref: float | None = None) -> float:
        """Sensible heat ``int int_{T_ref}^{T} rho c_p dT' dV`` (J), default T_ref: initial.

        Exact for constant rho c_p (``1^T C (T - T_ref)``); for temperature-dependent
        rho c_p the inner integral uses 4-point Gauss-Legendre at each volume Gauss point.
        """
        T = self.check_temperature(T)
        Tr = float(self.panel.initial_temperature if T_ref is None else T_ref)
        if self._const is not None:
            return float(np.sum(self._matrix(self._const[0]) @ (T - Tr)))
        Tq = T[self.mesh.elements] @ self._N.T
        xg, wg = np.polynomial.legendre.leggauss(4)
        total = np.zeros_like(Tq)
        for x, w in zip(xg, wg):  # four integration points in temperature
            Tt = Tr + 0.5 * (x + 1.0) * (Tq - Tr)
            rc = self._fields(Tt, False)[0]
            total += 0.5 * w * rc * (Tq - Tr)
        return float(np.sum(self._detJ[:, None] * total))
