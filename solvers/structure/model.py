"""Structural model of a panel: DCS9 assembly, boundary conditions and operators (Ch. 3).

:class:`StructuralModel` is built once per panel (mesh, quadrature data, CSR sparsity
pattern, penalty data) and evaluates the discrete operators of the equations of motion
(Eq. 3.43)::

    M u_tt + C u_t + F_I(u, T) = F_S

Public operators (``n_dof = 5 n_nodes``, DOF ``5 node + k`` with k = u, v, w, psi_x, psi_y;
SI units: m, rad, N, Pa, K):

* :meth:`StructuralModel.internal_force` -- ``F_I(u, T)`` (N), Eqs. (3.36), (3.40)
* :meth:`StructuralModel.tangent` -- exact ``dF_I/du`` (N/m), Eq. (3.50)
* :meth:`StructuralModel.linear_stiffness`, :meth:`StructuralModel.geometric_stiffness`
  -- ``K_L`` (Eq. 3.34a-b) and the initial-stress matrix (the ``L_w2^T N_E`` term of 3.52)
* :meth:`StructuralModel.mass` (Eq. 3.38), :meth:`StructuralModel.damping` (Eq. 3.44)
* :meth:`StructuralModel.pressure_load` (Eq. 3.39) and :attr:`pressure_matrix`
* :meth:`StructuralModel.thermal_load` (Eq. 3.34d)
* :meth:`StructuralModel.penalty_stiffness` -- ``K^c`` of the boundary conditions (Eqs. 3.40-3.42)
* :meth:`StructuralModel.laminate_at_nodes`, :meth:`StructuralModel.laminate_at_quadrature`
  -- the laminate resultants of a temperature field; :meth:`StructuralModel.element_dofs`
  -- ``u`` per element, the input of the kernels in :mod:`hypate.solvers.structure.element`

Temperature input ``T`` everywhere: ``None`` (the stress-free initial temperature), a scalar
(uniform), an array of shape ``(n_levels,)`` (one through-thickness profile for every node),
``(n_nodes,)`` (per node, uniform through the thickness) or ``(n_nodes, n_levels)`` at the
thermal levels ``hypate.solvers.panel.thermal_levels(panel)``; the laminate integrals use the
profile interpolated to the quadrature points with the shape functions.

Solvers on top of it: :mod:`hypate.solvers.structure.static` (nonlinear equilibrium),
:mod:`hypate.solvers.structure.modal` (modes, buckling) and
:mod:`hypate.solvers.structure.dynamics` (generalized-alpha, Eq. 3.45).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import cast

import numpy as np
import scipy.sparse as sp
from hypate.solvers.errors import InputError
from hypate.solvers.laminate import LaminateState, laminate
from hypate.solvers.numerics.sparse import Factor, PatternSolver
from hypate.solvers.panel import PanelSpec, thermal_levels
from hypate.solvers.structure.element import (
    NDOF,
    NNODE,
    Quadrature,
    btdb,
    btdb_von_karman,
    generalized_strain,
    geometric_kernel,
    mass_kernel,
    membrane_bending_B,
    shear_B,
    von_karman_w_B,
)
from hypate.solvers.structure.mesh import ShellMesh, panel_mesh
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
TemperatureLike = float | ArrayLike | None

#: Penalty factor alpha_0 of Eq. (3.42).
PENALTY_FACTOR = 1.0e6

U, V, W, PSI_X, PSI_Y = range(NDOF)


@dataclass(frozen=True)
class _ThermalState:
    """Laminate data at the quadrature points for one temperature field."""

    C: Array   # (E|1, 9|1, 6, 6)  [[A, B], [B, D]]
    R: Array   # (E|1, 9|1, 6)     (N_T, M_T)
    S: Array   # (E|1, 4|1, 2, 2)
    I: tuple[Array, ...]  # (E|1, 9|1) inertia I1, I2, I3 (Eq. 3.38)
    # u-independent kernel parts, formed on first use (StructuralModel._linear_tangent)
    linear: dict = field(default_factory=dict)


class StructuralModel:
    """Discrete DCS9 model of a panel (mesh, quadrature, sparsity pattern, penalty BCs).

    Parameters
    ----------
    panel : PanelSpec
        Layer stack, geometry, curvature, boundary condition and mesh size.
    mesh : ShellMesh, optional
        Defaults to :func:`hypate.solvers.structure.mesh.panel_mesh`.
    penalty : float
        alpha_0 of Eq. (3.42): the penalty stiffness is ``alpha_0 * max |K_L|`` of the
        unconstrained linear stiffness at the initial temperature (fixed for the model, so
        ``F_I`` and its tangent stay consistent).
    factorization : {"auto", "banded", "splu"}
        Back end of :class:`hypate.solvers.numerics.sparse.PatternSolver`.
    """

    def __init__(self, panel: PanelSpec, mesh: ShellMesh | None = None,
                 penalty: float = PENALTY_FACTOR, factorization: str = "auto") -> None:
        if not panel.layers:
            raise InputError("panel.layers", "at least one layer is needed")
        self.panel = panel
        self.mesh = mesh if mesh is not None else panel_mesh(panel)
        self.kx = 0.0 if math.isinf(panel.radius_x) else 1.0 / panel.radius_x
        self.ky = 0.0 if math.isinf(panel.radius_y) else 1.0 / panel.radius_y
        self.T0 = float(panel.initial_temperature)
        self.n_levels = int(thermal_levels(panel).size)
        m = self.mesh
        self.n_nodes = m.n_nodes
        self.n_dof = NDOF * m.n_nodes
        E = m.n_elem
        xe = m.coords[m.elements]
        self.q3 = Quadrature.on(xe, 3)   # membrane, bending, von Karman, mass
        self.q2 = Quadrature.on(xe, 2)   # transverse shear (reduced)
        self.edofs = (NDOF * m.elements[:, :, None] + np.arange(NDOF)).reshape(E, NNODE * NDOF)
        self._build_pattern()
        self._Bs = shear_B(self.q2, self.kx, self.ky).reshape(E, 4, 2, NNODE * NDOF)
        self._B0 = membrane_bending_B(self.q3, None, self.kx, self.ky).reshape(
            E, 9, 6, NNODE * NDOF)
        self._cache_key: object = None
        self._cache_state: _ThermalState | None = None
        self._mass_cache: dict[object, sp.csr_matrix] = {}
        self.constrained_dofs = self._constrained_dofs()
        self.free_dofs = np.setdiff1d(np.arange(self.n_dof), self.constrained_dofs)
        self.penalty = 0.0
        KLu = self.linear_stiffness(None, constrained=False)
        self._k_max = float(np.max(np.abs(KLu.data)))
        self.penalty = float(penalty) * self._k_max   # Eq. (3.42)
        self._pen_vec = np.zeros(self.n_dof)
        self._pen_vec[self.constrained_dofs] = self.penalty
        self._tie, self._tie_data = self._strip_ties()
        self.solver = PatternSolver(self.pattern, method=factorization,
                                    orderings=self._grid_orderings())
        self.pressure_matrix = self._build_pressure_matrix()

    # -- set-up ---------------------------------------------------------------------
    def _build_pattern(self) -> None:
        n = self.n_dof
        ed = self.edofs.astype(np.int64)
        nd = ed.shape[1]
        rows = np.broadcast_to(ed[:, :, None], (ed.shape[0], nd, nd)).ravel()
        cols = np.broadcast_to(ed[:, None, :], (ed.shape[0], nd, nd)).ravel()
        keys = rows * n + cols
        uniq, inv = np.unique(keys, return_inverse=True)
        self._map = inv.astype(np.int64)
        self._nnz = int(uniq.size)
        r = uniq // n
        self._indices = (uniq % n).astype(np.int32)
        self._indptr = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=n))]).astype(
            np.int32)
        self._diag = np.searchsorted(uniq, np.arange(n, dtype=np.int64) * (n + 1))
        self.pattern = self._csr(np.zeros(self._nnz))

    def _csr(self, data: Array) -> sp.csr_matrix:
        return sp.csr_matrix((data, self._indices, self._indptr), shape=(self.n_dof, self.n_dof))

    def assemble_matrix(self, Ke: Array, penalty: bool = False) -> sp.csr_matrix:
        """Assemble element matrices (n_elem, 45, 45) into CSR with the fixed pattern."""
        # float64 (numpy's stub types every bincount as intp, weighted too)
        data = cast(Array, np.bincount(self._map, weights=Ke.ravel(), minlength=self._nnz))
        if penalty:
            self._add_penalty(data)
        return self._csr(data)

    def _add_penalty(self, data: Array) -> None:
        """Add ``K^c`` (Eqs. 3.40-3.42, with the 2d-strip ties) to CSR data on the pattern."""
        data[self._diag] += self._pen_vec
        if self._tie_data is not None:
            data += self._tie_data

    def penalty_stiffness(self) -> sp.csr_matrix:
        """Penalty stiffness ``K^c`` of the boundary conditions (Eqs. 3.40-3.42), CSR (N/m).

        :attr:`penalty` on the diagonal of every DOF in :attr:`constrained_dofs`, plus the
        ties of a "2d" strip. :meth:`internal_force` contains ``K^c u`` and :meth:`tangent`
        contains ``K^c``: ``tangent(u, T) - penalty_stiffness()`` is the tangent of the
        unconstrained panel, ``penalty_stiffness() @ u`` the penalty reactions.
        """
        data = np.zeros(self._nnz)
        self._add_penalty(data)
        return self._csr(data)

    def assemble_vector(self, fe: Array) -> Array:
        """Assemble element vectors (n_elem, 45) into a global vector (n_dof,)."""
        return cast(Array, np.bincount(self.edofs.ravel(), weights=fe.ravel(),
                                       minlength=self.n_dof))  # float64: see assemble_matrix

    def _constrained_dofs(self) -> NDArray[np.intp]:
        """DOFs held at zero by the penalty method (Eqs. 3.40-3.42).

        Simply supported: w = 0 and in-plane immovable (u = v = 0) on every edge; the
        rotation about the edge is free and the rotation along it is held (psi_y = 0 on
        x-edges, psi_x = 0 on y-edges, the "hard" support matching the Navier solutions).
        Clamped: all five DOFs. A "2d" strip holds v = psi_y = 0 on every node and applies
        the edge condition on x = 0 and x = a only.
        """
        m = self.mesh
        bc = self.panel.boundary
        if bc not in ("simply_supported", "clamped"):
            raise InputError("panel.boundary", "must be 'simply_supported' or 'clamped'")
        dofs: list[NDArray[np.intp]] = []
        xedges = np.concatenate([m.edges["x0"], m.edges["xa"]])
        yedges = np.concatenate([m.edges["y0"], m.edges["yb"]])
        if self.panel.kind == "2d":
            allnodes = np.arange(m.n_nodes)
            dofs += [NDOF * allnodes + V, NDOF * allnodes + PSI_Y]
            yedges = yedges[:0]
        for nodes, held_rot in ((xedges, PSI_Y), (yedges, PSI_X)):
            if bc == "clamped":
                ks = [U, V, W, PSI_X, PSI_Y]
            else:
                ks = [U, V, W, held_rot]
            dofs += [NDOF * nodes + k for k in ks]
        return np.unique(np.concatenate(dofs)) if dofs else np.zeros(0, dtype=np.int64)

    def _penalty_force(self, u: Array) -> Array:
        """Penalty reactions K^c u (Eq. 3.40) including the 2d-strip ties."""
        f = self._pen_vec * u
        if self._tie is not None:
            f = f + self._tie @ u
        return f

    def _strip_ties(self) -> tuple[sp.csr_matrix | None, Array | None]:
        """Penalty ties making a "2d" strip a true cylindrical-bending model.

        The strip is one element across; without ties its w, u and psi_x may vary across
        the three node rows, and a heated strip then shows spurious spanwise modes (found
        unstable by the LSA in compression). Each of these DOFs of rows 0 and 2 is tied to
        row 1 by a penalty spring, so every field is independent of y. The tie stiffness is
        10 x max|K_L| (not the boundary penalty): a spring between two free DOFs as stiff
        as the boundary penalty would cancel the element stiffness to round-off.
        """
        tie_k = 10.0 * self._k_max
        if self.panel.kind != "2d":
            return None, None
        ni = self.mesh.grid_shape[1]
        i = np.arange(ni)
        a_nodes = np.concatenate([i, 2 * ni + i])      # rows 0 and 2
        b_nodes = np.concatenate([ni + i, ni + i])     # row 1
        rows, cols, vals = [], [], []
        for k in (U, W, PSI_X):
            a, b = NDOF * a_nodes + k, NDOF * b_nodes + k
            rows += [a, b, a, b]
            cols += [a, b, b, a]
            vals += [np.full(a.size, tie_k), np.full(a.size, tie_k),
                     np.full(a.size, -tie_k), np.full(a.size, -tie_k)]
        tie = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                            shape=(self.n_dof, self.n_dof))
        tie.sum_duplicates()
        # scatter into the element pattern (the tied pairs share an element)
        coo = tie.tocoo()
        keys = coo.row.astype(np.int64) * self.n_dof + coo.col
        rr = np.repeat(np.arange(self.n_dof), np.diff(self._indptr))
        pattern_keys = rr.astype(np.int64) * self.n_dof + self._indices
        pos = np.searchsorted(pattern_keys, keys)
        data = np.zeros(self._nnz)
        np.add.at(data, pos, coo.data)
        return tie, data

    def _grid_orderings(self) -> list[NDArray[np.intp]]:
        """DOF permutations of the natural grid orderings (x fastest, y fastest)."""
        nj, ni = self.mesh.grid_shape
        ids = np.arange(self.n_nodes).reshape(nj, ni)
        out = []
        for nodes in (ids.ravel(), ids.T.ravel()):
            out.append((NDOF * nodes[:, None] + np.arange(NDOF)).ravel())
        return out

    def _build_pressure_matrix(self) -> sp.csr_matrix:
        q = self.q3
        NN = np.einsum("eq,qa,qb->eab", q.wdet, q.N, q.N)                 # (E, 9, 9)
        el = self.mesh.elements
        rows = np.broadcast_to((NDOF * el + W)[:, :, None], NN.shape).ravel()
        cols = np.broadcast_to(el[:, None, :], NN.shape).ravel()
        return sp.csr_matrix((NN.ravel(), (rows, cols)), shape=(self.n_dof, self.n_nodes))

    # -- temperature ----------------------------------------------------------------
    def nodal_temperature(self, T: TemperatureLike) -> Array | float:
        """Normalize a temperature input: a float (uniform, no in-plane variation), an array
        of shape (n_levels,) (one profile) or (n_nodes, n_levels)."""
        if T is None:
            return self.T0
        arr = np.asarray(T, dtype=float)
        if arr.ndim == 0:
            return float(arr)
        if arr.ndim == 1 and arr.size == self.n_nodes:
            return np.repeat(arr[:, None], self.n_levels, axis=1)
        if arr.ndim == 1 and arr.size == self.n_levels:
            return arr
        if arr.shape == (self.n_nodes, self.n_levels):
            return arr
        raise InputError("temperature", "expected a scalar or shape "
                         f"(n_levels,)=({self.n_levels},),"
                         f" (n_nodes,)=({self.n_nodes},) or (n_nodes, n_levels), got {arr.shape}")

    def _cached_thermal(self, Tn: Array | float) -> _ThermalState | None:
        """The cached laminate data when they are for the normalized temperature ``Tn``."""
        if self._cache_state is None:
            return None
        ck = self._cache_key
        if isinstance(Tn, float):
            return self._cache_state if isinstance(ck, float) and ck == Tn else None
        if isinstance(ck, np.ndarray) and ck.shape == np.shape(Tn) and np.array_equal(ck, Tn):
            return self._cache_state
        return None

    def _thermal(self, T: TemperatureLike) -> _ThermalState:
        Tn = self.nodal_temperature(T)
        cached = self._cached_thermal(Tn)
        if cached is not None:
            return cached
        if isinstance(Tn, float) or Tn.ndim == 1:
            lam = laminate(self.panel, Tn)
            st = _ThermalState(C=lam.ABD[None, None], R=lam.thermal_resultants[None, None],
                               S=lam.S[None, None],
                               I=tuple(np.asarray(x)[None, None] for x in (lam.I1, lam.I2,
                                                                           lam.I3)))
        else:
            lam3 = laminate(self.panel, self.at_points(Tn, self.q3))
            lam2 = laminate(self.panel, self.at_points(Tn, self.q2),
                            parts="shear")  # only S at the reduced shear quadrature
            st = _ThermalState(C=lam3.ABD, R=lam3.thermal_resultants, S=lam2.S,
                               I=(lam3.I1, lam3.I2, lam3.I3))
        self._cache_key = Tn if isinstance(Tn, float) else np.array(Tn, copy=True)
        self._cache_state = st
        return st

    def laminate_at_nodes(self, T: TemperatureLike = None) -> LaminateState:
        """Laminate resultants (A, B, D, S, N_T, M_T, I1..I3) at every node, leading shape
        (n_nodes,) (or () for a uniform temperature)."""
        Tn = self.nodal_temperature(T)
        return laminate(self.panel, Tn)

    def laminate_at_quadrature(self, T: TemperatureLike = None) -> LaminateState:
        """Laminate resultants (A, B, D, S, N_T, M_T, I1..I3; Eqs. 3.34, 3.38) at the 3 x 3
        Gauss points of every element, where the stiffness, thermal load and mass are
        integrated: leading shape (n_elem, 9), or () for a temperature without in-plane
        variation. The nodal profiles are interpolated to the points with the shape
        functions (module docstring)."""
        Tn = self.nodal_temperature(T)
        if isinstance(Tn, float) or Tn.ndim == 1:
            return laminate(self.panel, Tn)
        return laminate(self.panel, self.at_points(Tn, self.q3))

    def at_points(self, Tn: Array, q: Quadrature) -> Array:
        """Nodal profiles (n_nodes, n_levels) at the points of ``q``, shape (E, n_qp, L)."""
        return np.einsum("qa,eal->eql", q.N, Tn[self.mesh.elements])

    # -- element kernels --------------------------------------------------------------
    def element_dofs(self, u: Array | None) -> Array | None:
        """The DOFs of every element, shape (n_elem, 9, 5) (nodes in the element's order,
        then u, v, w, psi_x, psi_y): the ``ue`` the kernels of
        :mod:`hypate.solvers.structure.element` take. ``None`` gives ``None``.

        Parameters
        ----------
        u : ndarray of shape (n_dof,) or None
            Nodal DOFs (m, rad).
        """
        if u is None:
            return None
        u = np.asarray(u, dtype=float)
        if u.shape != (self.n_dof,):
            raise ValueError(f"u must have shape ({self.n_dof},), got {u.shape}")
        return u[self.edofs].reshape(-1, NNODE, NDOF)

    def _linear_tangent(self, st: _ThermalState) -> Array:
        """``btdb(B0, C) + btdb(Bs, S)`` (E, 45, 45), the u-independent part of the element
        tangent, formed once per temperature field (a coupled step evaluates several
        tangents at one temperature)."""
        if "K0" not in st.linear:
            st.linear["K0"] = (btdb(self._B0, st.C, self.q3.wdet)
                               + btdb(self._Bs, st.S, self.q2.wdet))
        return st.linear["K0"]

    def _kernel(self, u: Array | None, T: TemperatureLike, force: bool, tangent: bool,
                nonlinear: bool = True, geometric: bool = True,
                thermal: bool = True) -> tuple[Array | None, Array | None]:
        """Element internal forces (E, 45) and tangents (E, 45, 45).

        ``B = B0 + BL`` (Eq. 3.32): the linear operator ``B0`` is fixed and the von Karman
        part ``BL`` lives on the membrane rows and w columns only, so the force is
        ``B0^T s + BL^T s_m`` and the tangent the cached ``B0^T C B0`` plus a rank-9 update
        per quadrature point (:func:`hypate.solvers.structure.element.btdb_von_karman`).
        """
        st = self._thermal(T)
        E = self.mesh.n_elem
        q3, q2 = self.q3, self.q2
        ue = self.element_dofs(u)
        if ue is None:
            ue = np.zeros((E, NNODE, NDOF))
        nl = nonlinear and u is not None
        BL = von_karman_w_B(q3, ue) if nl else None                        # (E, 9, 3, 9)
        e6 = generalized_strain(q3, ue, self.kx, self.ky, nonlinear=nl)
        stress = np.einsum("...ij,...j->...i", st.C, e6)                   # (E, 9, 6)
        if thermal:
            stress = stress - st.R
        fe = Ke = None
        gam = np.einsum("eqia,ea->eqi", self._Bs, ue.reshape(E, -1))      # (E, 4, 2)
        if force:
            shear = np.einsum("...ij,...j->...i", st.S, gam)
            # sum_q B^T s as one (1 x 6q) (6q x 45) product per element
            sw = stress * q3.wdet[..., None]
            ss = shear * q2.wdet[..., None]
            fe = (np.matmul(sw.reshape(E, 1, -1), self._B0.reshape(E, -1, NNODE * NDOF))
                  + np.matmul(ss.reshape(E, 1, -1), self._Bs.reshape(E, -1, NNODE * NDOF))
                  )[:, 0]
            if BL is not None:  # i.e. nl
                fe.reshape(E, NNODE, NDOF)[:, :, W] += np.matmul(
                    np.ascontiguousarray(sw[..., :3]).reshape(E, 1, -1),
                    BL.reshape(E, -1, NNODE))[:, 0]
        if tangent:
            K0 = self._linear_tangent(st)
            Ke = (btdb_von_karman(K0, self._B0, st.C * q3.wdet[..., None, None], BL)
                  if BL is not None else K0.copy())  # i.e. nl
            if geometric:
                Kg = geometric_kernel(q3, stress[..., :3])
                Ke.reshape(E, NNODE, NDOF, NNODE, NDOF)[:, :, W, :, W] += Kg
        return fe, Ke

    # -- public operators -------------------------------------------------------------
    def internal_force(self, u: Array, T: TemperatureLike = None) -> Array:
        """Internal force ``F_I(u, T) = K(u) u - F_T + K^c u`` (Eqs. 3.36, 3.40).

        Parameters
        ----------
        u : ndarray of shape (n_dof,)
            Nodal DOFs (m, rad).
        T : temperature input (see module docstring), K.

        Returns
        -------
        ndarray of shape (n_dof,), N.
        """
        fe, _ = self._kernel(u, T, force=True, tangent=False)
        assert fe is not None  # force=True
        return self.assemble_vector(fe) + self._penalty_force(u)

    def tangent(self, u: Array, T: TemperatureLike = None) -> sp.csr_matrix:
        """Exact tangent ``dF_I/du`` (Eq. 3.50, with dK_N/du u and dF_T/du), CSR (N/m)."""
        _, Ke = self._kernel(u, T, force=False, tangent=True)
        assert Ke is not None  # tangent=True
        return self.assemble_matrix(Ke, penalty=True)

    def force_and_tangent(self, u: Array, T: TemperatureLike = None
                          ) -> tuple[Array, sp.csr_matrix]:
        """``(F_I, dF_I/du)`` from one kernel pass."""
        fe, Ke = self._kernel(u, T, force=True, tangent=True)
        assert fe is not None and Ke is not None  # force=True, tangent=True
        return (self.assemble_vector(fe) + self._penalty_force(u),
                self.assemble_matrix(Ke, penalty=True))

    def linear_stiffness(self, T: TemperatureLike = None,
                         constrained: bool = True) -> sp.csr_matrix:
        """Linear stiffness ``K_L = K_L1 + K_L2`` (Eq. 3.34a-b) with properties at ``T``
        (no initial-stress term); plus the penalty ``K^c`` when ``constrained``."""
        _, Ke = self._kernel(None, T, force=False, tangent=True, geometric=False)
        assert Ke is not None  # tangent=True
        return self.assemble_matrix(Ke, penalty=constrained)

    def membrane_resultants(self, u: Array | None, T: TemperatureLike = None,
                            nonlinear: bool = True) -> Array:
        """``(N_E, M_E)`` at the 3 x 3 quadrature points (Eq. 3.7), shape (n_elem, 9, 6)."""
        st = self._thermal(T)
        E = self.mesh.n_elem
        ue = self.element_dofs(u)
        if ue is None:
            ue = np.zeros((E, NNODE, NDOF))
        e6 = generalized_strain(self.q3, ue, self.kx, self.ky, nonlinear=nonlinear)
        return np.einsum("...ij,...j->...i", st.C, e6) - st.R

    def geometric_stiffness(self, u: Array | None = None, T: TemperatureLike = None,
                            nonlinear: bool = True) -> sp.csr_matrix:
        """Initial-stress matrix of the membrane resultants at ``(u, T)`` on the w DOFs
        (the ``L_w2^T N_E`` term of Eq. 3.52), CSR (N/m), no penalty."""
        res = self.membrane_resultants(u, T, nonlinear=nonlinear)
        Kg = geometric_kernel(self.q3, res[..., :3])
        E = self.mesh.n_elem
        Ke = np.zeros((E, NNODE, NDOF, NNODE, NDOF))
        Ke[:, :, W, :, W] = Kg
        return self.assemble_matrix(Ke.reshape(E, NNODE * NDOF, NNODE * NDOF))

    def thermal_load(self, T: TemperatureLike, u: Array | None = None) -> Array:
        """Thermal load vector ``F_T`` (Eq. 3.34d) at ``(u, T)``, shape (n_dof,), N."""
        st = self._thermal(T)
        E = self.mesh.n_elem
        ue = self.element_dofs(u)
        B = (self._B0 if ue is None else
             membrane_bending_B(self.q3, ue, self.kx, self.ky).reshape(E, 9, 6, NNODE * NDOF))
        R = np.broadcast_to(st.R, (E, 9, 6))
        fe = np.einsum("eqia,eqi->ea", B, R * self.q3.wdet[..., None])
        return self.assemble_vector(fe)

    def mass(self, T: TemperatureLike = None) -> sp.csr_matrix:
        """Consistent mass matrix (Eq. 3.38) with densities at ``T`` (default: initial), CSR."""
        Tn = self.nodal_temperature(T)
        key = Tn if isinstance(Tn, float) else (np.asarray(Tn).tobytes())
        if key in self._mass_cache:
            return self._mass_cache[key]
        cached = self._cached_thermal(Tn)
        if cached is not None:  # the stiffness at this temperature evaluated the inertia
            I1, I2, I3 = cached.I
        elif isinstance(Tn, float) or Tn.ndim == 1:
            lam = laminate(self.panel, Tn, parts="inertia")
            I1, I2, I3 = (np.asarray(x)[None, None] for x in (lam.I1, lam.I2, lam.I3))
        else:
            lam = laminate(self.panel, self.at_points(Tn, self.q3), parts="inertia")
            I1, I2, I3 = lam.I1, lam.I2, lam.I3
        # assembled from the entries the kernel can make nonzero only (the rest are exact
        # zeros: the same sums)
        Me = mass_kernel(self.q3, I1, I2, I3).ravel()
        sel, slots = self._mass_entries
        M = self._csr(cast(Array, np.bincount(slots, weights=Me[sel], minlength=self._nnz)))
        if len(self._mass_cache) > 8:
            self._mass_cache.clear()
        self._mass_cache[key] = M
        return M

    @cached_property
    def _mass_entries(self) -> tuple[NDArray[np.intp], NDArray[np.int64]]:
        """Where the element mass of Eq. (3.38) can be nonzero -- like DOFs, u-psi_x and
        v-psi_y, a fifth of the 45 x 45 entries -- as flat positions in the (n_elem, 45, 45)
        kernel and their CSR slots; every other entry is an exact zero for any inertia."""
        ones = np.ones(self.q3.wdet.shape)
        sel = np.flatnonzero(mass_kernel(self.q3, ones, ones, ones).ravel())
        return sel, self._map[sel]

    @cached_property
    def mass_slots(self) -> NDArray[np.int64]:
        """The CSR slots of the pattern where the mass matrix can be nonzero, sorted."""
        return np.unique(self._mass_entries[1])

    def damping(self, T: TemperatureLike = None) -> sp.csr_matrix:
        """Proportional damping ``C = zeta_M M + zeta_K K_L`` (Eq. 3.44), CSR."""
        zm, zk = self.panel.damping
        return self._csr(zm * self.mass(T).data + zk * self.linear_stiffness(T).data)

    def pressure_load(self, p: ArrayLike) -> Array:
        """Load vector ``F_S`` of a pressure (Pa, positive towards +z), Eq. (3.39).

        Parameters
        ----------
        p : float, ndarray of shape (n_nodes,) or (n_elem, 9)
            Uniform, nodal (interpolated with the shape functions) or at the 3 x 3
            quadrature points of every element.

        Returns
        -------
        ndarray of shape (n_dof,), N. For nodal pressure this is ``pressure_matrix @ p``,
        so ``dF_S/du = pressure_matrix @ dp/du``.
        """
        p = np.asarray(p, dtype=float)
        if p.ndim == 0:
            return self.pressure_matrix @ np.full(self.n_nodes, float(p))
        if p.shape == (self.n_nodes,):
            return self.pressure_matrix @ p
        if p.shape == (self.mesh.n_elem, 9):
            E = self.mesh.n_elem
            fe = np.zeros((E, NNODE, NDOF))
            fe[:, :, W] = np.einsum("eq,qa->ea", p * self.q3.wdet, self.q3.N)
            return self.assemble_vector(fe.reshape(E, -1))
        raise InputError("pressure", f"expected a scalar, shape ({self.n_nodes},) or "
                         f"({self.mesh.n_elem}, 9), got {p.shape}")

    # -- helpers ----------------------------------------------------------------------
    def dofs(self, k: int) -> NDArray[np.intp]:
        """Global indices of DOF ``k`` (0..4 = u, v, w, psi_x, psi_y) of every node."""
        return NDOF * np.arange(self.n_nodes) + k

    def deflection(self, u: Array) -> Array:
        """w of every node, shape (n_nodes,)."""
        return np.asarray(u)[W::NDOF]

    def factor(self, K: sp.csr_matrix) -> Factor:
        """Factorize a matrix with the model's pattern (see
        :mod:`hypate.solvers.numerics.sparse`)."""
        return self.solver.factor(K)
