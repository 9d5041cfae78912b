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

Size: over 600 lines because :class:`ThermalModel` is one object -- the fixed pattern, its
scatter maps and the factor cache are shared by the volume terms, the boundary terms and
the Newton iteration -- and splitting it would pass that state between modules.
"""
from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal, Union

import numpy as np
import scipy.sparse as sp
from hypate.solvers.errors import InputError
from hypate.solvers.materials import STEFAN_BOLTZMANN, Material
from hypate.solvers.numerics.banded import BandedStorage, Factorization, SparseLU
from hypate.solvers.numerics.threads import blas_threads
from hypate.solvers.panel import PanelSpec
from hypate.solvers.thermal.element import (
    hex_reference,
    quad_reference,
    rotate_conductivity,
)
from hypate.solvers.thermal.march import StepResult, ThermalHistory, simulate
from hypate.solvers.thermal.mesh import HexMesh, build_hex_mesh
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: A wall heat-flux model: ``flux(T_wall) -> (q, dq_dT)`` with ``T_wall`` the surface nodal
#: temperatures, shape (n_inplane,), ``q`` the nodal flux into the surface (W/m^2), shape
#: (n_inplane,), and ``dq_dT`` its derivative: ``None`` (zero), shape (n_inplane,) for a
#: nodal (diagonal) dependence, or an (n_inplane, n_inplane) dense/sparse matrix.
FluxFunction = Callable[[Array], tuple[Array, Union[Array, sp.spmatrix, None]]]

#: Why a banded factorization failed, in the thermal model's words.
SINGULAR_JACOBIAN = ("singular thermal Jacobian (a steady problem needs a prescribed "
                     "temperature, radiation or convection somewhere)")


# ---------------------------------------------------------------------------------------
# Boundary conditions
# ---------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class SurfaceCondition:
    """Thermal condition on the upper or lower surface (Eq. 4.24); default: insulated.

    Attributes
    ----------
    flux : None, float, ndarray or FluxFunction
        Heat flux *into* the surface (W/m^2): a uniform value; nodal values of shape
        (n_inplane,) (consistent load ``M_s q`` with the surface mass matrix); values at the
        2 x 2 Gauss points of shape (n_cells, 4); or a callable ``flux(T_wall) ->
        (q, dq_dT)`` evaluated at the Crank-Nicolson temperature ``T^alpha`` of the surface
        nodes, so an aerodynamic heat flux can be implicit in the wall temperature
        (its derivative enters the Newton Jacobian, Eq. 4.30b). ``dq_dT`` may also be a
        zero-argument callable returning it: it is then called only when the Jacobian is
        needed (a residual-only evaluation skips it).
    emissivity : float
        Emissivity for radiation ``eps sigma (T^4 - T_rad^4)`` leaving the surface; 0 = off.
    T_rad : float
        Temperature of the radiative surroundings (K).
    h : float
        Convection coefficient (W/(m^2 K)); 0 = off.
    T_ambient : float or ndarray of shape (n_inplane,)
        Convection reference (e.g. adiabatic-wall) temperature (K).
    nodal_load : bool
        If True, ``flux`` (array or callable) gives nodal heat *inputs* in W, shape
        (n_inplane,), used as they are (e.g. ``H_TF q`` from a fluid grid, Eq. 5.1b), and a
        callable's derivative is in W/K. This keeps a cell-local ``dq/dT_w`` on the fixed
        sparsity pattern (banded solver); ``M_s`` times it would reach two cells away.
    """

    flux: float | Array | FluxFunction | None = None
    emissivity: float = 0.0
    T_rad: float = 0.0
    h: float = 0.0
    T_ambient: float | Array = 0.0
    nodal_load: bool = False

    @property
    def is_insulated(self) -> bool:
        return self.flux is None and self.emissivity == 0.0 and self.h == 0.0


@dataclass(frozen=True, eq=False)
class ThermalLoads:
    """All thermal boundary conditions of a step (sides of the panel are insulated).

    Attributes
    ----------
    top, bottom : SurfaceCondition
        Upper (``z = +h/2``, flow side) and lower surface.
    prescribed_nodes : ndarray of int, optional
        Thermal node ids with prescribed temperature (Eq. 4.26).
    prescribed_values : float or ndarray, optional
        Their temperatures (K), broadcast to ``prescribed_nodes``.
    penalty : float
        Penalty number alpha-tilde of Eq. (4.27) relative to the largest diagonal entry of
        the unconstrained system (the absolute value is ``penalty * max diag``).
    """

    top: SurfaceCondition = field(default_factory=SurfaceCondition)
    bottom: SurfaceCondition = field(default_factory=SurfaceCondition)
    prescribed_nodes: IntArray | None = None
    prescribed_values: float | Array | None = None
    penalty: float = 1e10


@dataclass(eq=False)
class _Evaluation:
    """Residual (W), its max-norm on free rows, the magnitude of its terms, the net
    boundary heat rate sum(Q) (W), the penalty-row residual over the penalty (K) and, on
    request, the Jacobian data (nnz,), an extra sparse
    Jacobian term outside the element pattern, and whether the Jacobian is symmetric."""

    R: Array
    rnorm: float
    ref: float
    heat_rate: float
    constraint_error: float = 0.0
    J: Array | None = None
    extra: sp.spmatrix | None = None
    symmetric: bool = False


# ---------------------------------------------------------------------------------------
# The model
# ---------------------------------------------------------------------------------------
class ThermalModel:
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

    def __init__(self, panel: PanelSpec, *, rtol: float = 1e-10, xtol: float = 1e-10,
                 max_iterations: int = 30, jacobian: Literal["full", "modified"] = "full",
                 chord_threshold: float = 1e-4,
                 contraction: float = 0.25, max_step_fraction: float = 0.5,
                 blas_threads: int | None = 1) -> None:
        if jacobian not in ("full", "modified"):
            raise InputError("jacobian", "must be 'full' or 'modified'")
        self.panel = panel
        self.rtol, self.xtol = float(rtol), float(xtol)
        self.max_iterations = int(max_iterations)
        self.jacobian_mode = jacobian
        self.contraction = float(contraction)
        self.chord_threshold = float(chord_threshold)
        self.blas_threads = blas_threads
        self.max_step_fraction = float(max_step_fraction)
        self.mesh = mesh = build_hex_mesh(panel)
        self.n_nodes = mesh.n_nodes
        self.n_inplane = mesh.n_inplane
        self.n_levels = mesh.n_levels
        self._setup_layers()
        self._setup_reference()
        frows, fcols = self._setup_pattern()
        self._setup_surface(frows, fcols)

        # -- caches ---------------------------------------------------------------------
        self._const: tuple[Array, Array] | None = None
        if self.constant_properties:
            T0 = np.full(self.n_nodes, float(panel.initial_temperature))
            C, K, _, _ = self._element_data(T0, None, jacobian=False)
            self._const = (C, K)
        self._factor: Factorization | None = None
        self._factor_data: Array | None = None
        self._factor_key: tuple | None = None
        self._factor_stale = False
        self._penalty_scale: dict[tuple, float] = {}
        self.factorizations = 0
        self.residual_evaluations = 0
        self._scatter_cache: tuple | None = None

    def _setup_layers(self) -> None:
        """Contiguous element slices per layer (elements are level-interval major) and
        the material groups."""
        panel, mesh = self.panel, self.mesh
        bounds = np.searchsorted(mesh.element_layer, np.arange(len(panel.layers) + 1))
        self._layer_slices = [slice(int(bounds[m]), int(bounds[m + 1]))
                              for m in range(len(panel.layers))]
        self._layer_rot = [(math.cos(layer.angle), math.sin(layer.angle))
                           for layer in panel.layers]
        # layers of one material at one angle (e.g. the two face sheets of a sandwich) have
        # their properties looked up together: (material, rotation, element rows)
        groups: dict[tuple[int, float], list[int]] = {}
        for m, layer in enumerate(panel.layers):
            groups.setdefault((id(layer.material), float(layer.angle)), []).append(m)
        self._material_groups: list[tuple[Material, tuple[float, float], slice | IntArray]] = []
        for members in groups.values():
            rows: slice | IntArray = (self._layer_slices[members[0]] if len(members) == 1
                                      else np.concatenate([np.arange(
                                          self._layer_slices[m].start,
                                          self._layer_slices[m].stop) for m in members]))
            self._material_groups.append((panel.layers[members[0]].material,
                                          self._layer_rot[members[0]], rows))
        props = ("k1", "k2", "k3", "density", "specific_heat")
        self.constant_properties = all(
            getattr(layer.material, p).is_constant for layer in panel.layers for p in props)
        self.constant_conductivity = all(
            getattr(layer.material, p).is_constant for layer in panel.layers
            for p in ("k1", "k2", "k3"))

    def _setup_reference(self) -> None:
        """Reference element (Eq. 4.18) and geometry (boxes: diagonal Jacobian)."""
        mesh = self.mesh
        N, dN = hex_reference()
        self._N = N
        self._dNt = dN.transpose(1, 0, 2).reshape(8, 24)  # [j, (q, b)] for grad T
        self._NN = np.einsum("qi,qj->qij", N, N).reshape(8, 64)
        self._GG = np.einsum("qia,qjb->qabij", dN, dN).reshape(72, 64)
        self._GN = np.einsum("qia,qj->qaij", dN, N).reshape(24, 64)
        self._Gt = dN.transpose(0, 2, 1).reshape(24, 8)  # [(q, a), i]
        h = mesh.element_size
        self._detJ = np.prod(h, axis=1) / 8.0  # Gauss weights are 1
        self._s = 2.0 / h  # d eta / d x
        N2 = quad_reference()
        self._N2 = N2
        self._NN2 = np.einsum("qi,qj->qij", N2, N2).reshape(4, 16)
        self._detJ2 = np.prod(mesh.face_size, axis=1) / 4.0

    def _setup_pattern(self) -> tuple[IntArray, IntArray]:
        """CSR pattern, volume/diagonal/surface scatter maps and the banded storage.

        Returns the rows and columns of the surface-cell matrices (for the surface mass).
        """
        mesh, n = self.mesh, self.n_nodes
        e = mesh.elements
        rows = np.repeat(e, 8, axis=1).ravel()
        cols = np.tile(e, (1, 8)).ravel()
        pattern = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n))
        pattern.sum_duplicates()
        pattern.sort_indices()
        self._indptr = pattern.indptr.astype(np.int64)
        self._indices = pattern.indices.astype(np.int64)
        self.nnz = int(self._indices.size)
        prow = np.repeat(np.arange(n), np.diff(self._indptr))
        keys = prow * n + self._indices
        self._keys = keys
        self._vol_map = np.searchsorted(keys, rows * n + cols)
        self._diag_map = np.searchsorted(keys, np.arange(n) * (n + 1))
        f = mesh.faces
        frows = np.repeat(f, 4, axis=1).ravel()
        fcols = np.tile(f, (1, 4)).ravel()
        off_top = (mesh.n_levels - 1) * mesh.n_inplane
        self._surf_map = {
            "bottom": np.searchsorted(keys, frows * n + fcols),
            "top": np.searchsorted(keys, (frows + off_top) * n + fcols + off_top),
        }
        self._surf_offset = {"bottom": 0, "top": off_top}
        self._banded = BandedStorage(banded_position(mesh), prow, self._indices)
        return frows, fcols

    def _setup_surface(self, frows: IntArray, fcols: IntArray) -> None:
        """Surface mass matrix and area/volume integration weights."""
        mesh, n = self.mesh, self.n_nodes
        e, f, N, N2 = mesh.elements, mesh.faces, self._N, self._N2
        M_face = self._detJ2[:, None] * self._NN2.sum(axis=0)[None, :]  # (n_cells, 16)
        self._M_face = M_face.reshape(-1, 4, 4)
        self.surface_mass = sp.csr_matrix(
            (M_face.ravel(), (frows, fcols)), shape=(self.n_inplane, self.n_inplane))
        self.area_weights = np.bincount(
            f.ravel(), weights=(self._detJ2[:, None] * N2.sum(axis=0)[None, :]).ravel(),
            minlength=self.n_inplane)
        self.volume_weights = np.bincount(
            e.ravel(), weights=(self._detJ[:, None] * N.sum(axis=0)[None, :]).ravel(),
            minlength=n)
        self.area = float(self.area_weights.sum())
        self.volume = float(self.volume_weights.sum())

    # ------------------------------------------------------------------------------------
    # Properties at quadrature points
    # ------------------------------------------------------------------------------------
    def _fields(self, Tq: Array, derivative: bool) -> tuple[Array, Array, Array, Array]:
        """rho c_p and the panel-axes conductivity (xx, yy, xy, zz) at Gauss points (Eq. 4.2).

        Returns ``rc (n_e, 8)``, ``drc``, ``k (n_e, 8, 4)``, ``dk`` (derivatives are zero
        arrays when ``derivative`` is False).
        """
        ne = Tq.shape[0]
        rc = np.empty((ne, 8))
        drc = np.zeros((ne, 8))
        k = np.empty((ne, 8, 4))
        dk = np.zeros((ne, 8, 4))
        for mat, (c, s), sl in self._material_groups:  # a handful of layer groups
            Tl = Tq[sl]
            if not derivative:  # values only (the same numbers, no slope look-ups)
                vals: dict[int, Array] = {}
                for prop in (mat.k1, mat.k2, mat.k3):
                    if id(prop) not in vals:
                        vals[id(prop)] = prop(Tl)
                k1, k2, k3 = (vals[id(p)] for p in (mat.k1, mat.k2, mat.k3))
                rc[sl] = mat.density(Tl) * mat.specific_heat(Tl)
                if c == 1.0 and s == 0.0:  # unrotated: rotate_conductivity's numbers, in place
                    k[sl, :, 0], k[sl, :, 1], k[sl, :, 2], k[sl, :, 3] = k1, k2, 0.0, k3
                else:
                    k[sl] = rotate_conductivity(np.stack([k1, k2, k3], axis=-1), c, s)
                continue
            kd, dkd = mat.conductivity(Tl)
            r, dr = mat.heat_capacity(Tl)
            rc[sl] = r
            k[sl] = rotate_conductivity(kd, c, s)
            drc[sl] = dr
            dk[sl] = rotate_conductivity(dkd, c, s)
        return rc, drc, k, dk

    def conductivity_tensor(self, layer: int, T: ArrayLike) -> Array:
        """Panel-axes conductivity tensor of a layer (Eq. 4.2 rotated by the layer angle).

        Parameters
        ----------
        layer : int
            Layer index (bottom = 0).
        T : array_like
            Temperatures (K), any shape.

        Returns
        -------
        ndarray of shape T.shape + (3, 3)
            W/(m K).
        """
        lay = self.panel.layers[layer]
        kd, _ = lay.material.conductivity(np.asarray(T, float))
        k4 = rotate_conductivity(kd, math.cos(lay.angle), math.sin(lay.angle))
        out = np.zeros(k4.shape[:-1] + (3, 3))
        out[..., 0, 0], out[..., 1, 1], out[..., 2, 2] = k4[..., 0], k4[..., 1], k4[..., 3]
        out[..., 0, 1] = out[..., 1, 0] = k4[..., 2]
        return out

    def _conduction_weights(self, k: Array) -> Array:
        """detJ s_a s_b k_ab at Gauss points, shape (n_e, 8, 3, 3)."""
        s, d = self._s, self._detJ[:, None]
        W = np.zeros(k.shape[:2] + (3, 3))
        W[..., 0, 0] = d * k[..., 0] * (s[:, 0] ** 2)[:, None]
        W[..., 1, 1] = d * k[..., 1] * (s[:, 1] ** 2)[:, None]
        W[..., 0, 1] = W[..., 1, 0] = d * k[..., 2] * (s[:, 0] * s[:, 1])[:, None]
        W[..., 2, 2] = d * k[..., 3] * (s[:, 2] ** 2)[:, None]
        return W

    def _element_data(self, T: Array, dT: Array | None, jacobian: bool
                      ) -> tuple[Array, Array, Array | None, Array | None]:
        """Assembled CSR data of C_T(T), K_T(T) (Eq. 4.23) and the Jacobian terms.

        Returns ``C, K`` and, when ``jacobian``, ``dC = (dC/dT) dT`` (Eq. 4.31a, needs
        ``dT``; None when ``dT`` is None) and ``dK = (dK/dT) T`` (Eq. 4.31b). All arrays
        have shape (nnz,) in the fixed pattern.
        """
        Te = T[self.mesh.elements]  # (n_e, 8)
        Tq = Te @ self._N.T  # (n_e, 8 qp)
        rc, drc, k, dk = self._fields(Tq, jacobian)
        C = self._assemble((self._detJ[:, None] * rc) @ self._NN)
        K = self._assemble(self._conduction_weights(k).reshape(-1, 72) @ self._GG)
        if not jacobian:
            return C, K, None, None
        dC = None
        if dT is not None:
            dTq = dT[self.mesh.elements] @ self._N.T
            dC = self._assemble((self._detJ[:, None] * drc * dTq) @ self._NN)
        # Eq. (4.31b): d/dT_j of int grad N_i . k(T) grad T = int grad N_i . (k' grad T) N_j
        g = (Te @ self._dNt).reshape(-1, 8, 3) * self._s[:, None, :]  # grad T at qp
        v = np.empty_like(g)
        v[..., 0] = dk[..., 0] * g[..., 0] + dk[..., 2] * g[..., 1]
        v[..., 1] = dk[..., 2] * g[..., 0] + dk[..., 1] * g[..., 1]
        v[..., 2] = dk[..., 3] * g[..., 2]
        U = v * self._s[:, None, :] * self._detJ[:, None, None]
        dK = self._assemble(U.reshape(-1, 24) @ self._GN)
        return C, K, dC, dK

    def _assemble(self, vals: Array) -> Array:
        """Scatter element matrices (n_e, 64) into CSR data (nnz,)."""
        return np.bincount(self._vol_map, weights=vals.ravel(), minlength=self.nnz)

    def _matrix(self, data: Array) -> sp.csr_matrix:
        return sp.csr_matrix((data, self._indices, self._indptr),
                             shape=(self.n_nodes, self.n_nodes))

    # ------------------------------------------------------------------------------------
    # Public matrices
    # ------------------------------------------------------------------------------------
    def capacity(self, T: ArrayLike) -> sp.csr_matrix:
        """Heat capacity matrix C_T(T), Eq. (4.23b), J/K, shape (n_nodes, n_nodes)."""
        T = self.check_temperature(T)
        if self._const is not None:
            return self._matrix(self._const[0].copy())
        return self._matrix(self._element_data(T, None, False)[0])

    def conductivity(self, T: ArrayLike) -> sp.csr_matrix:
        """Unconstrained conductivity matrix K_T^u(T), Eq. (4.23a), W/K."""
        T = self.check_temperature(T)
        if self._const is not None:
            return self._matrix(self._const[1].copy())
        return self._matrix(self._element_data(T, None, False)[1])

    def capacity_jacobian(self, T: ArrayLike, dT: ArrayLike) -> sp.csr_matrix:
        """``(dC_T/dT) dT`` of Eq. (4.31a): column j is ``(dC_T / dT_j) dT``; W s/K^2 * K."""
        T, dT = self.check_temperature(T), self.check_temperature(dT)
        return self._matrix(self._element_data(T, dT, True)[2])

    def conductivity_jacobian(self, T: ArrayLike) -> sp.csr_matrix:
        """``(dK_T/dT) T`` of Eq. (4.31b): column j is ``(dK_T / dT_j) T`` (W/K)."""
        T = self.check_temperature(T)
        return self._matrix(self._element_data(T, None, True)[3])

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
            return np.bincount(self.mesh.faces.ravel(), weights=vals.ravel(),
                               minlength=self.n_inplane)
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

    # ------------------------------------------------------------------------------------
    # Residual, Jacobian, Newton
    # ------------------------------------------------------------------------------------
    def check_temperature(self, T: ArrayLike) -> Array:
        """``T`` as a float array of shape (n_nodes,); ``InputError`` for another shape."""
        T = np.asarray(T, dtype=float)
        if T.shape != (self.n_nodes,):
            raise InputError("temperature", f"expected shape ({self.n_nodes},), got {T.shape}")
        return T

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

    def _evaluate(self, T1: Array, T0: Array | None, dt: float | None, alpha: float,
                  loads: ThermalLoads, jacobian: bool) -> _Evaluation:
        """Residual of Eq. (4.28) (transient) or ``K T - Q`` (steady) and its Jacobian."""
        self.residual_evaluations += 1
        steady = dt is None
        a = 1.0 if steady else alpha
        Ta = T1 if steady else (1.0 - a) * T0 + a * T1
        dT = None if steady else T1 - T0
        Kx, Cx, Jvol = self._volume_terms(Ta, dT, dt, a, jacobian)
        Q, D, extra, mag = self._boundary(Ta, loads, a, jacobian)
        R = Kx - Q
        ref = max(float(np.max(np.abs(Kx))), mag)
        if Cx is not None:
            R += Cx
            ref = max(ref, float(np.max(np.abs(Cx))))
        nodes, values = self._prescribed(loads)
        pen = 0.0
        if nodes.size:
            pen = self._penalty_value(loads, dt, alpha)
            R[nodes] += pen * (T1[nodes] - values)  # penalty on T^{n+1} (see step())
            free = np.ones(self.n_nodes, bool)
            free[nodes] = False
            rnorm = float(np.max(np.abs(R[free]))) if free.any() else 0.0
            perr = float(np.max(np.abs(R[nodes]))) / pen
        else:
            rnorm = float(np.max(np.abs(R)))
            perr = 0.0
        out = _Evaluation(R=R, rnorm=rnorm, ref=ref, heat_rate=float(Q.sum()),
                          constraint_error=perr)
        if not jacobian:
            return out
        # Eq. (4.29): dR/dT^{n+1} - dQ/dT^{n+1}; D is already alpha dQ/dT^alpha (Eq. 4.30b)
        J = Jvol - D
        if nodes.size:
            np.add.at(J, self._diag_map[nodes], pen)
        out.J = J
        out.extra = -extra if extra is not None else None
        out.symmetric = (self.constant_conductivity and extra is None
                         and not self._has_nodal_flux_derivative(loads))
        return out

    def _volume_terms(self, Ta: Array, dT: Array | None, dt: float | None, a: float,
                      jacobian: bool) -> tuple[Array, Array | None, Array | None]:
        """Conduction ``K(T^a) T^a``, capacity ``C(T^a) dT/dt`` (nodal, W) and the volume
        part of the Jacobian, Eq. (4.30a), as CSR data (nnz,) when ``jacobian``.

        With temperature-dependent properties the nodal vectors are integrated directly at
        the Gauss points (no element matrices) and the Jacobian is formed element-wise and
        scattered once.
        """
        steady = dt is None
        if self._const is not None:
            C, K = self._const
            Kx = self._matrix(K) @ Ta
            Cx = None if steady else self._matrix(C) @ (dT / dt)
            J = None
            if jacobian:
                J = a * K if steady else a * K + C / dt
            return Kx, Cx, J
        el = self.mesh.elements
        Te = Ta[el]
        Tq = Te @ self._N.T  # (n_e, 8 qp)
        rc, drc, k, dk = self._fields(Tq, jacobian)
        s, det = self._s[:, None, :], self._detJ[:, None, None]
        g = (Te @ self._dNt).reshape(-1, 8, 3) * s  # grad T^a at the Gauss points
        f = np.empty_like(g)  # k grad T (Eq. 4.16)
        f[..., 0] = k[..., 0] * g[..., 0] + k[..., 2] * g[..., 1]
        f[..., 1] = k[..., 2] * g[..., 0] + k[..., 1] * g[..., 1]
        f[..., 2] = k[..., 3] * g[..., 2]
        r = (f * s * det).reshape(-1, 24) @ self._Gt  # (n_e, 8)
        Kx = np.bincount(el.ravel(), weights=r.ravel(), minlength=self.n_nodes)
        Cx = dTq = None
        if not steady:
            dTq = dT[el] @ self._N.T
            rcap = (self._detJ[:, None] * rc * dTq / dt) @ self._N
            Cx = np.bincount(el.ravel(), weights=rcap.ravel(), minlength=self.n_nodes)
        if not jacobian:
            return Kx, Cx, None
        Je = a * (self._conduction_weights(k).reshape(-1, 72) @ self._GG)  # a K (4.23a)
        if not steady:
            # C/dt (4.23b) + Term 1 of Eq. (4.30a): (a/dt) (dC/dT) dT, Eq. (4.31a)
            Je += (self._detJ[:, None] * (rc + a * drc * dTq) / dt) @ self._NN
        if not self.constant_conductivity:
            # Term 2 of Eq. (4.30a): a (dK/dT) T, Eq. (4.31b)
            v = np.empty_like(g)
            v[..., 0] = dk[..., 0] * g[..., 0] + dk[..., 2] * g[..., 1]
            v[..., 1] = dk[..., 2] * g[..., 0] + dk[..., 1] * g[..., 1]
            v[..., 2] = dk[..., 3] * g[..., 2]
            Je += a * ((v * s * det).reshape(-1, 24) @ self._GN)
        return Kx, Cx, self._assemble(Je)

    @staticmethod
    def _has_nodal_flux_derivative(loads: ThermalLoads) -> bool:
        return any(callable(getattr(loads, s).flux) for s in ("top", "bottom"))

    def residual(self, T_new: ArrayLike, T_old: ArrayLike | None, dt: float | None,
                 loads: ThermalLoads, alpha: float = 0.5) -> Array:
        """Residual of the Crank-Nicolson equations (Eq. 4.28 minus Q_T), W.

        ``R = C(T^a) (T^{n+1} - T^n)/dt + K(T^a) T^a - Q(T^a) + alpha~ (T^{n+1} - T_b)``
        on prescribed nodes; with ``dt=None`` the steady residual ``K(T) T - Q(T)``.

        Returns
        -------
        ndarray of shape (n_nodes,)
        """
        T1 = self.check_temperature(T_new)
        T0 = None if dt is None else self.check_temperature(T_old)
        return self._evaluate(T1, T0, dt, float(alpha), loads, False).R

    def jacobian(self, T_new: ArrayLike, T_old: ArrayLike | None, dt: float | None,
                 loads: ThermalLoads, alpha: float = 0.5) -> sp.csr_matrix:
        """Exact Jacobian dR/dT^{n+1} of :meth:`residual`, Eqs. (4.29)-(4.32), W/K."""
        T1 = self.check_temperature(T_new)
        T0 = None if dt is None else self.check_temperature(T_old)
        ev = self._evaluate(T1, T0, dt, float(alpha), loads, True)
        assert ev.J is not None
        M = self._matrix(ev.J)
        return M + ev.extra if ev.extra is not None else M

    def _factorize(self, J: Array, extra: sp.spmatrix | None, symmetric: bool,
                   key: tuple) -> Factorization:
        """Factor the Jacobian unless the cached factor is of the identical matrix."""
        if (extra is None and self._factor is not None and self._factor_key == key
                and self._factor_data is not None and np.array_equal(J, self._factor_data)):
            return self._factor
        self.factorizations += 1
        factor: Factorization | None = None
        if extra is not None:
            try:
                factor = SparseLU(self._matrix(J) + extra)
            except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
                raise np.linalg.LinAlgError(f"singular thermal Jacobian: {exc}") from exc
            self._factor, self._factor_data = factor, None
        else:
            try:
                if symmetric:
                    factor = self._banded.cholesky(J)
                if factor is None:
                    factor = self._banded.lu(J)
            except np.linalg.LinAlgError as exc:  # a negligible pivot (numerics.banded)
                raise np.linalg.LinAlgError(SINGULAR_JACOBIAN) from exc
            self._factor, self._factor_data = factor, J.copy()
        self._factor_key = key
        self._factor_stale = False
        return factor

    def _newton(self, T_start: Array, T_old: Array | None, dt: float | None, alpha: float,
                loads: ThermalLoads, jacobian: str | None = None,
                contraction: float | None = None) -> StepResult:
        with blas_threads(self.blas_threads):
            return self._newton_iterations(T_start, T_old, dt, alpha, loads,
                                           jacobian or self.jacobian_mode,
                                           self.contraction if contraction is None
                                           else float(contraction))

    def _newton_iterations(self, T_start: Array, T_old: Array | None, dt: float | None,
                           alpha: float, loads: ThermalLoads, jacobian: str,
                           contraction: float) -> StepResult:
        """Newton-Raphson with backtracking line search on ||R||_2 (Sec. 4.2.4)."""
        f0 = self.factorizations
        nodes, _ = self._prescribed(loads)
        key = (dt, alpha, hash(np.sort(nodes).tobytes()))
        modified = jacobian == "modified"
        T = T_start.copy()
        fresh_factor = False
        # with the full Jacobian the first iteration always forms it at T_start: evaluate it
        # with the residual once (the same residual, bit for bit) instead of twice
        ev = self._evaluate(T, T_old, dt, alpha, loads, not modified)
        converged = False
        it = 0
        while it < self.max_iterations:
            scale = max(1.0, float(np.max(np.abs(T))))
            if (ev.rnorm <= self.rtol * ev.ref or ev.rnorm == 0.0) \
                    and ev.constraint_error <= self.xtol * scale:
                converged = True
                break
            # Chord iterations with this step's factorization once the residual is small
            # (quadratic phase: the stale Jacobian still contracts by ~|dJ| |J^-1| << 1).
            chord = (fresh_factor and not self._factor_stale
                     and ev.rnorm <= self.chord_threshold * ev.ref)
            use_cached = chord or (modified and self._factor is not None
                                   and not self._factor_stale and self._factor_key == key)
            if use_cached:
                factor = self._factor
            else:
                # ev.J is only set by the start evaluation, at the current T
                full = ev if ev.J is not None else self._evaluate(T, T_old, dt, alpha, loads,
                                                                  True)
                assert full.J is not None
                factor = self._factorize(full.J, full.extra, full.symmetric, key)
                fresh_factor = True
            assert factor is not None
            delta = -factor.solve(ev.R)
            it += 1
            # Line search on phi(s) = ||R(T + s delta)||^2 / 2 with quadratic backtracking.
            phi0 = 0.5 * float(ev.R @ ev.R)
            newton_step = float(np.max(np.abs(delta)))
            s = min(1.0, self.max_step_fraction * scale / max(newton_step, 1e-300))
            for _ in range(12):
                trial = self._evaluate(T + s * delta, T_old, dt, alpha, loads, False)
                phit = 0.5 * float(trial.R @ trial.R)
                if phit <= (1.0 - 2e-4 * s) * phi0 or (trial.rnorm <= self.rtol * trial.ref and
                                                        trial.constraint_error <= self.xtol
                                                        * scale):
                    break
                curv = (phit - phi0 + 2.0 * phi0 * s) / (s * s)
                s = min(0.5 * s, max(0.1 * s, phi0 / curv))
            else:
                self._factor_stale = True  # no descent: refresh a frozen Jacobian
            if use_cached and phit > contraction**2 * phi0:
                self._factor_stale = True  # slow contraction: refactor next iteration
            T = T + s * delta
            ev = trial
            if newton_step <= self.xtol * scale:  # the full Newton increment is negligible
                converged = True
                break
        if not converged:
            warnings.warn(f"thermal Newton did not converge in {self.max_iterations} "
                          f"iterations (residual {ev.rnorm:.3e} W, reference {ev.ref:.3e} W)",
                          RuntimeWarning, stacklevel=3)
        heat = ev.heat_rate * (1.0 if dt is None else dt)
        return StepResult(T=T, iterations=it, factorizations=self.factorizations - f0,
                          residual_norm=ev.rnorm, converged=converged, heat_input=heat)

    # ------------------------------------------------------------------------------------
    # Solvers
    # ------------------------------------------------------------------------------------
    def step(self, T_old: ArrayLike, dt: float, loads: ThermalLoads, *, alpha: float = 0.5,
             T_guess: ArrayLike | None = None,
             jacobian: Literal["full", "modified"] | None = None,
             contraction: float | None = None) -> StepResult:
        """One Crank-Nicolson step, Eq. (4.28), solved by Newton-Raphson with line search.

        The residual is

            C(T^a) (T^{n+1} - T^n)/dt + K(T^a) T^a - Q(T^a) = 0,
            T^a = (1 - alpha) T^n + alpha T^{n+1},

        with the Jacobian of Eqs. (4.30)-(4.32) (capacity, conductivity, radiation and
        flux-function derivatives). Prescribed temperatures are imposed by the penalty of
        Eq. (4.27) on ``T^{n+1}`` (not on ``T^a``: with ``alpha = 1/2`` that would make
        ``T^{n+1} = 2 T_b - T^n`` oscillate when the initial state violates the constraint;
        both are identical once ``T^n`` satisfies it).

        Parameters
        ----------
        T_old : ndarray of shape (n_nodes,)
            Temperatures at t_n (K).
        dt : float
            Time step (s), > 0.
        loads : ThermalLoads
            Boundary conditions, evaluated at ``T^a`` (time t_n + alpha dt).
        alpha : float
            alpha-bar in (0, 1]; 1/2 is Crank-Nicolson, 1 backward Euler.
        T_guess : ndarray of shape (n_nodes,), optional
            Newton start (default ``T_old``).
        jacobian, contraction : optional
            Override the model's ``jacobian`` mode and ``contraction`` for this step (the
            same solution to ``rtol``/``xtol``; a caller marching smooth steps keeps the
            last step's factorization with ``"modified"`` and a strict ``contraction``).

        Returns
        -------
        StepResult
        """
        if jacobian not in (None, "full", "modified"):
            raise InputError("jacobian", "must be 'full' or 'modified'")
        T0 = self.check_temperature(T_old)
        if not (dt > 0.0 and math.isfinite(dt)):
            raise InputError("time_step", "must be > 0 (s)")
        if not (0.0 < alpha <= 1.0):
            raise InputError("alpha", "alpha-bar must be in (0, 1]")
        start = T0 if T_guess is None else self.check_temperature(T_guess)
        return self._newton(start, T0, float(dt), float(alpha), loads, jacobian, contraction)

    def steady(self, loads: ThermalLoads, T_guess: ArrayLike | None = None) -> StepResult:
        """Steady state ``K_T(T) T = Q_T(T)`` (Eq. 4.27 without the capacity term).

        Needs a prescribed temperature, convection or radiation to be well posed.
        ``T_guess`` (default: the initial temperature) starts the Newton iteration.
        """
        start = (np.full(self.n_nodes, float(self.panel.initial_temperature))
                 if T_guess is None else self.check_temperature(T_guess))
        return self._newton(start, None, None, 1.0, loads)

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


def banded_position(mesh: HexMesh) -> IntArray:
    """Place of every thermal node in the banded ordering of the Jacobian, shape (n_nodes,).

    The through-thickness index runs fastest and the in-plane direction with fewer nodes
    next, which gives a half bandwidth of about ``n_levels (min(n_x, n_y) + 1)`` (measured:
    3-10x faster than SuperLU on these meshes).
    """
    nl, nxn, nyn = mesh.n_levels, mesh.x.size, mesh.y.size
    node = np.arange(mesh.n_nodes)
    k, p = np.divmod(node, mesh.n_inplane)
    j, i = np.divmod(p, nxn)
    new = (j * nxn + i) * nl + k if nxn <= nyn else (i * nyn + j) * nl + k
    return new.astype(np.int64)


def uniform_loads(q: float, emissivity: float, T_rad: float) -> ThermalLoads:
    """Uniform flux ``q`` into the upper surface, radiation to ``T_rad`` (the CLI case)."""
    return ThermalLoads(top=SurfaceCondition(flux=float(q), emissivity=float(emissivity),
                                             T_rad=float(T_rad)))
