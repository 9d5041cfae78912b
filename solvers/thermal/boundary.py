"""The thermal model's boundary terms (Eqs. 4.23c, 4.24, 4.26-4.27, 4.30b-4.32): prescribed
fluxes (uniform, nodal, at the Gauss points or a function of the wall temperature), convection,
radiation and the penalty of the prescribed temperatures, with their Jacobians on the fixed
pattern of :mod:`.assembly`.
"""
from __future__ import annotations

from typing import cast

import numpy as np
import scipy.sparse as sp
from hypate.solvers.errors import InputError
from hypate.solvers.materials import STEFAN_BOLTZMANN
from hypate.solvers.thermal.assembly import ThermalAssembly
from hypate.solvers.thermal.loads import SurfaceCondition, ThermalLoads
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]


class ThermalBoundary(ThermalAssembly):
    """Boundary loads and the penalty of prescribed temperatures on the assembled model."""

    def flux_load(self, q: float | ArrayLike, surface: str = "top") -> Array:
        """Consistent nodal load of a prescribed flux into a surface (Eq. 4.23c), W.

        Parameters
        ----------
        q : float or ndarray of shape (n_inplane,) or (n_cells, 4)
            Uniform value, nodal values (load ``M_s q``) or values at the 2 x 2 Gauss
            points of each surface cell (W/m^2, positive into the panel).
        surface : {"top", "bottom"}

        Returns
        -------
        ndarray of shape (n_nodes,)
        """
        out = np.zeros(self.n_nodes)
        off = self._surface_offset(surface)
        out[off:off + self.n_inplane] = self._surface_flux(np.asarray(q, float))
        return out

    def _surface_flux(self, q: Array) -> Array:
        if q.ndim == 0:
            return float(q) * self.area_weights
        if q.shape == (self.n_inplane,):
            return self.surface_mass @ q
        if q.shape == (self.mesh.n_cells, 4):
            vals = (self._detJ2[:, None] * q) @ self._N2  # (n_cells, 4 nodes)
            # float64 (numpy's stub types every bincount as intp, weighted too)
            return cast(Array, np.bincount(self.mesh.faces.ravel(), weights=vals.ravel(),
                                           minlength=self.n_inplane))
        raise InputError("flux", f"heat flux must be a number, shape ({self.n_inplane},) "
                         f"(nodal) or ({self.mesh.n_cells}, 4) (Gauss points); got {q.shape}")

    def radiation(self, T: ArrayLike, emissivity: float, T_rad: float,
                  surface: str = "top") -> tuple[Array, sp.csr_matrix]:
        """Radiation load ``-int N eps sigma (T^4 - T_rad^4)`` and its derivative.

        Eq. (4.24) with Eqs. (4.31c)-(4.32); ``T`` interpolated to the 2 x 2 Gauss points.

        Returns
        -------
        Q : ndarray of shape (n_nodes,)
            Nodal heat input (W).
        dQ : csr_matrix of shape (n_nodes, n_nodes)
            dQ/dT (W/K).
        """
        T = self.check_temperature(T)
        Q = np.zeros(self.n_nodes)
        D = np.zeros(self.nnz)
        self._add_radiation(T, float(emissivity), float(T_rad), surface, Q, D, 1.0)
        return Q, self._matrix(D)

    def _surface_offset(self, surface: str) -> int:
        if surface not in self._surf_offset:
            raise InputError("surface", "must be 'top' or 'bottom'")
        return self._surf_offset[surface]

    def _add_radiation(self, T: Array, eps: float, T_rad: float, surface: str, Q: Array,
                       D: Array, scale: float) -> float:
        off = self._surface_offset(surface)
        Tf = T[self.mesh.faces + off] @ self._N2.T  # (n_cells, 4 qp)
        es = eps * STEFAN_BOLTZMANN
        w = self._detJ2[:, None]
        qout = es * (Tf**4 - T_rad**4)
        vals = -(w * qout) @ self._N2
        Q += np.bincount(self.mesh.faces.ravel() + off, weights=vals.ravel(),
                         minlength=self.n_nodes)
        jac = -(w * 4.0 * es * Tf**3) @ self._NN2  # Eq. (4.32)
        D += scale * np.bincount(self._surf_map[surface], weights=jac.ravel(),
                                 minlength=self.nnz)
        return float(np.max(np.abs(vals))) if vals.size else 0.0

    def boundary_load(self, T: ArrayLike, loads: ThermalLoads
                      ) -> tuple[Array, sp.csr_matrix]:
        """Total unconstrained boundary load Q_T^u(T) (W) and dQ_T^u/dT (W/K), Eq. (4.24).

        Penalty terms (Eq. 4.27) are not included; see :meth:`residual`.
        """
        T = self.check_temperature(T)
        Q, D, extra, _ = self._boundary(T, loads, 1.0)
        J = self._matrix(D)
        return Q, (J + extra if extra is not None else J)

    def _boundary(self, T: Array, loads: ThermalLoads, scale: float, jacobian: bool = True
                  ) -> tuple[Array, Array, sp.spmatrix | None, float]:
        """Q (n_nodes,), scale * dQ/dT data (nnz,), optional extra sparse dQ/dT (pattern
        outside the element pattern, scaled) and the magnitude of the load terms.

        Without ``jacobian`` a flux function's derivative is not formed (D and extra then
        miss its term; only Q and the magnitude are meaningful)."""
        Q = np.zeros(self.n_nodes)
        D = np.zeros(self.nnz)
        extra: sp.spmatrix | None = None
        mag = 0.0
        n_in = self.n_inplane
        for name in ("top", "bottom"):
            bc: SurfaceCondition = getattr(loads, name)
            if bc.is_insulated:
                continue
            off = self._surf_offset[name]
            sl = slice(off, off + n_in)
            if bc.flux is not None:
                if callable(bc.flux):
                    q, dq = bc.flux(T[sl].copy())
                    q = np.asarray(q, float)
                    if q.shape != (n_in,):
                        raise InputError("flux", f"flux function must return shape ({n_in},)")
                    fq = q if bc.nodal_load else self.surface_mass @ q
                    if not jacobian:
                        dq = None
                    elif callable(dq):
                        dq = dq()
                    if dq is not None:
                        if sp.issparse(dq) or np.ndim(dq) == 2:
                            term = self._surface_matrix_term(dq, off, scale, D,
                                                             bc.nodal_load)
                            if term is not None:
                                extra = term if extra is None else extra + term
                        elif bc.nodal_load:
                            dqv = np.broadcast_to(np.asarray(dq, float), (n_in,))
                            D[self._diag_map[off:off + n_in]] += scale * dqv
                        else:
                            dqv = np.broadcast_to(np.asarray(dq, float), (n_in,))
                            vals = self._M_face * dqv[self.mesh.faces][:, None, :]
                            D += scale * np.bincount(self._surf_map[name],
                                                     weights=vals.ravel(), minlength=self.nnz)
                elif bc.nodal_load:
                    fq = np.broadcast_to(np.asarray(bc.flux, float), (n_in,)).copy()
                else:
                    fq = self._surface_flux(np.asarray(bc.flux, float))
                Q[sl] += fq
                mag = max(mag, float(np.max(np.abs(fq))))
            if bc.h != 0.0:
                Tamb = np.broadcast_to(np.asarray(bc.T_ambient, float), (n_in,))
                fc = bc.h * (self.surface_mass @ (Tamb - T[sl]))
                Q[sl] += fc
                mag = max(mag, float(np.max(np.abs(bc.h * self.surface_mass @ Tamb))))
                D += scale * np.bincount(self._surf_map[name], weights=-bc.h
                                         * self._M_face.ravel(), minlength=self.nnz)
            if bc.emissivity != 0.0:
                mag = max(mag, self._add_radiation(T, bc.emissivity, bc.T_rad, name, Q, D,
                                                   scale))
        return Q, D, extra, mag

    def _surface_matrix_term(self, dq: ArrayLike | sp.spmatrix, off: int, scale: float,
                             D: Array, nodal_load: bool = False) -> sp.spmatrix | None:
        """Add ``scale * M_s dq/dT`` (``scale * dq/dT`` for nodal loads) for a matrix
        flux derivative.

        Scattered into the fixed pattern ``D`` when every entry falls on it (e.g. a nodal or
        element-local coupling); otherwise returned as a sparse (n_nodes, n_nodes) term
        (the Jacobian is then factorized with SuperLU).
        """
        n = self.n_nodes
        if nodal_load and isinstance(dq, sp.csr_matrix) and dq.has_canonical_format:
            # a flux Jacobian on a fixed pattern (the coupling's): scatter map cached
            c = self._scatter_cache
            if not (c is not None and c[0] == off and c[1] is dq.indptr and c[2] is dq.indices):
                rows = np.repeat(np.arange(dq.shape[0], dtype=np.int64), np.diff(dq.indptr))
                gk = (rows + off) * n + dq.indices.astype(np.int64) + off
                idx = np.minimum(np.searchsorted(self._keys, gk), self.nnz - 1)
                idx = idx if np.all(self._keys[idx] == gk) else None
                self._scatter_cache = c = (off, dq.indptr, dq.indices, idx)
            if c[3] is not None:
                D += scale * np.bincount(c[3], weights=dq.data, minlength=self.nnz)
                return None
        Md = sp.coo_matrix(sp.csr_matrix(dq) if nodal_load
                           else self.surface_mass @ sp.csr_matrix(dq))
        Md.sum_duplicates()
        gk = (Md.row.astype(np.int64) + off) * n + Md.col.astype(np.int64) + off
        idx = np.minimum(np.searchsorted(self._keys, gk), self.nnz - 1)
        if np.all(self._keys[idx] == gk):
            D += scale * np.bincount(idx, weights=Md.data, minlength=self.nnz)
            return None
        return sp.csr_matrix((scale * Md.data, (Md.row + off, Md.col + off)), shape=(n, n))


    def _prescribed(self, loads: ThermalLoads) -> tuple[IntArray, Array]:
        if loads.prescribed_nodes is None:
            return np.zeros(0, np.int64), np.zeros(0)
        nodes = np.asarray(loads.prescribed_nodes, dtype=np.int64).ravel()
        if nodes.size and (nodes.min() < 0 or nodes.max() >= self.n_nodes):
            raise InputError("prescribed_nodes", f"node ids must be in [0, {self.n_nodes})")
        vals = np.broadcast_to(np.asarray(loads.prescribed_values, float), nodes.shape)
        return nodes, np.array(vals, dtype=float)

    def _penalty_value(self, loads: ThermalLoads, dt: float | None, alpha: float) -> float:
        """alpha-tilde of Eq. (4.27): ``penalty`` times the largest diagonal entry of the
        unconstrained Jacobian at the initial temperature (cached per dt, alpha)."""
        key = (dt, alpha)
        if key not in self._penalty_scale:
            if len(self._penalty_scale) > 64:  # e.g. adaptive time steps: keep it small
                self._penalty_scale.clear()
            T0 = np.full(self.n_nodes, float(self.panel.initial_temperature))
            C, K = self._const if self._const is not None else \
                self._element_data(T0, None, False)[:2]
            diag = alpha * K[self._diag_map]
            if dt is not None:
                diag = diag + C[self._diag_map] / dt
            self._penalty_scale[key] = float(np.max(np.abs(diag)))
        return loads.penalty * self._penalty_scale[key]
