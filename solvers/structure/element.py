"""The DCS9 element: 9-node doubly-curved shallow shell (Eqs. 3.29-3.39, 3.50-3.54).

Declarative part: quadratic Lagrange shape functions (Eq. 3.31), the 3 x 3 Gauss rule for
membrane, bending, the von Karman terms and the mass, and the 2 x 2 rule for transverse
shear (selective reduced integration against shear locking, Fig. 3.2).

Kernels: pure functions on arrays of shape ``(n_elem, n_qp, ...)``; no loop over elements or
quadrature points. Nodal DOFs per element ``ue`` have shape ``(n_elem, 9, 5)`` ordered
``(u, v, w, psi_x, psi_y)``; element vectors are ``(n_elem, 45)`` and element matrices
``(n_elem, 45, 45)`` with local index ``5 * a + k`` (node ``a``, DOF ``k``).

Generalized strains (Eq. 3.2, shallow shell, FSDT, von Karman)::

    eps0 = [u_x + w / R_x + w_x^2 / 2,  v_y + w / R_y + w_y^2 / 2,  u_y + v_x + w_x w_y]
    chi  = [psi_x,x,  psi_y,y,  psi_x,y + psi_y,x]
    gam  = [-u / R_x + w_x + psi_x,  -v / R_y + w_y + psi_y]          # (xz, yz)

(the sign of the ``v / R_y`` term follows the operator L3 of Eq. 3.32, symmetric in x and y).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: DOFs per node: u, v, w, psi_x, psi_y.
NDOF = 5
#: Nodes per element.
NNODE = 9


def _f(x: Array) -> Array:
    """1D quadratic Lagrange functions f1..f3 of Eq. (3.31) at ``x``, shape x.shape + (3,)."""
    return np.stack([0.5 * x * (x - 1.0), 1.0 - x * x, 0.5 * x * (x + 1.0)], axis=-1)


def _df(x: Array) -> Array:
    return np.stack([x - 0.5, -2.0 * x, x + 0.5], axis=-1)


def shape_functions(xi: Array, eta: Array) -> tuple[Array, Array]:
    """Shape functions ``N_{3s+r} = f_r(xi) f_s(eta)`` and parametric derivatives.

    Returns
    -------
    N : ndarray of shape (n_pts, 9)
    dN : ndarray of shape (n_pts, 9, 2)
        ``dN/dxi``, ``dN/deta``.
    """
    xi = np.atleast_1d(np.asarray(xi, dtype=float))
    eta = np.atleast_1d(np.asarray(eta, dtype=float))
    fx, fy = _f(xi), _f(eta)
    dfx, dfy = _df(xi), _df(eta)
    N = np.einsum("ps,pr->psr", fy, fx).reshape(-1, 9)
    dNx = np.einsum("ps,pr->psr", fy, dfx).reshape(-1, 9)
    dNy = np.einsum("ps,pr->psr", dfy, fx).reshape(-1, 9)
    return N, np.stack([dNx, dNy], axis=-1)


def gauss_rule(n: int) -> tuple[Array, Array]:
    """Tensor Gauss-Legendre rule on [-1, 1]^2: points (n^2, 2) and weights (n^2,).

    Points are ordered with xi fastest, like the local nodes.
    """
    x, w = np.polynomial.legendre.leggauss(n)
    X, Y = np.meshgrid(x, x)
    W = np.outer(w, w)
    return np.column_stack([X.ravel(), Y.ravel()]), W.ravel()


@dataclass(frozen=True, eq=False)
class Quadrature:
    """Shape data of one Gauss rule on every element of a mesh.

    Attributes
    ----------
    N : ndarray of shape (n_qp, 9)
    dN : ndarray of shape (n_elem, n_qp, 9, 2)
        Physical derivatives ``dN/dx``, ``dN/dy``.
    wdet : ndarray of shape (n_elem, n_qp)
        Gauss weight times the Jacobian determinant (m^2).
    """

    N: Array
    dN: Array
    wdet: Array

    @classmethod
    def on(cls, coords: Array, order: int) -> Quadrature:
        """Quadrature of ``order x order`` points on elements with node coordinates
        ``coords`` of shape (n_elem, 9, 2)."""
        pts, wts = gauss_rule(order)
        N, dNp = shape_functions(pts[:, 0], pts[:, 1])
        J = np.einsum("qak,eai->eqik", dNp, coords)          # dx_i / dxi_k
        det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
        if np.any(det <= 0.0):
            raise ValueError("degenerate or inverted element (non-positive Jacobian)")
        Jinv = np.empty_like(J)
        Jinv[..., 0, 0] = J[..., 1, 1] / det
        Jinv[..., 1, 1] = J[..., 0, 0] / det
        Jinv[..., 0, 1] = -J[..., 0, 1] / det
        Jinv[..., 1, 0] = -J[..., 1, 0] / det
        dN = np.einsum("qak,eqki->eqai", dNp, Jinv)
        return cls(N=N, dN=dN, wdet=det * wts[None, :])


def membrane_bending_B(q: Quadrature, ue: Array | None, kx: float, ky: float) -> Array:
    """Strain-displacement operator of (eps0, chi): ``L1 + Lw`` and ``L2`` of Eq. (3.32).

    ``d(eps0, chi) = B du``; with ``ue = None`` the linear operator (``Lw = 0``).

    Returns
    -------
    ndarray of shape (n_elem, n_qp, 6, 9, 5)
    """
    E, nq = q.dN.shape[:2]
    Nx, Ny = q.dN[..., 0], q.dN[..., 1]
    N = np.broadcast_to(q.N, (E, nq, NNODE))
    B = np.zeros((E, nq, 6, NNODE, NDOF))
    B[:, :, 0, :, 0] = Nx
    B[:, :, 1, :, 1] = Ny
    B[:, :, 2, :, 0] = Ny
    B[:, :, 2, :, 1] = Nx
    B[:, :, 0, :, 2] = kx * N
    B[:, :, 1, :, 2] = ky * N
    if ue is not None:
        wx = np.einsum("eqa,ea->eq", Nx, ue[..., 2])[..., None]
        wy = np.einsum("eqa,ea->eq", Ny, ue[..., 2])[..., None]
        B[:, :, 0, :, 2] += wx * Nx                       # Lw, Eq. (3.32)
        B[:, :, 1, :, 2] += wy * Ny
        B[:, :, 2, :, 2] = wy * Nx + wx * Ny
    B[:, :, 3, :, 3] = Nx
    B[:, :, 4, :, 4] = Ny
    B[:, :, 5, :, 3] = Ny
    B[:, :, 5, :, 4] = Nx
    return B


def generalized_strain(q: Quadrature, ue: Array, kx: float, ky: float,
                       nonlinear: bool = True) -> Array:
    """(eps0, chi) at the quadrature points, Eq. (3.2), shape (n_elem, n_qp, 6)."""
    # gradients (E, q, 5, 2); matmul, 4x faster than the equivalent einsum
    g = np.matmul(q.dN.transpose(0, 1, 3, 2), ue[:, None]).transpose(0, 1, 3, 2)
    w = ue[..., 2] @ q.N.T
    e = np.empty(g.shape[:2] + (6,))
    e[..., 0] = g[..., 0, 0] + kx * w
    e[..., 1] = g[..., 1, 1] + ky * w
    e[..., 2] = g[..., 0, 1] + g[..., 1, 0]
    if nonlinear:
        wx, wy = g[..., 2, 0], g[..., 2, 1]
        e[..., 0] += 0.5 * wx * wx
        e[..., 1] += 0.5 * wy * wy
        e[..., 2] += wx * wy
    e[..., 3] = g[..., 3, 0]
    e[..., 4] = g[..., 4, 1]
    e[..., 5] = g[..., 3, 1] + g[..., 4, 0]
    return e


def shear_B(q: Quadrature, kx: float, ky: float) -> Array:
    """Transverse shear operator L3 of Eq. (3.32), rows (xz, yz).

    Returns
    -------
    ndarray of shape (n_elem, n_qp, 2, 9, 5)
    """
    E, nq = q.dN.shape[:2]
    N = np.broadcast_to(q.N, (E, nq, NNODE))
    B = np.zeros((E, nq, 2, NNODE, NDOF))
    B[:, :, 0, :, 0] = -kx * N
    B[:, :, 0, :, 2] = q.dN[..., 0]
    B[:, :, 0, :, 3] = N
    B[:, :, 1, :, 1] = -ky * N
    B[:, :, 1, :, 2] = q.dN[..., 1]
    B[:, :, 1, :, 4] = N
    return B


def btdb(B: Array, C: Array, wdet: Array) -> Array:
    """``sum_q wdet B^T C B`` for B (E, q, m, 45) and C broadcastable to (E, q, m, m).

    Returns
    -------
    ndarray of shape (E, 45, 45)
    """
    E, nq, m, n = B.shape
    CB = np.matmul(C * wdet[..., None, None], B)           # (E, q, m, 45)
    return np.matmul(B.reshape(E, nq * m, n).transpose(0, 2, 1), CB.reshape(E, nq * m, n))


def von_karman_w_B(q: Quadrature, ue: Array) -> Array:
    """The nonlinear part ``Lw`` of Eq. (3.32) on the w DOFs: ``membrane_bending_B(q, ue)``
    minus ``membrane_bending_B(q, None)`` is zero except rows (eps_x, eps_y, gamma_xy) and
    the w columns, where it is ``(w_x N_a,x, w_y N_a,y, w_y N_a,x + w_x N_a,y)``.

    Returns
    -------
    ndarray of shape (n_elem, n_qp, 3, 9)
    """
    Nx, Ny = q.dN[..., 0], q.dN[..., 1]
    w = ue[:, None, :, 2, None]                                        # (E, 1, 9, 1)
    wx, wy = np.matmul(Nx[..., None, :], w)[..., 0], np.matmul(Ny[..., None, :], w)[..., 0]
    BL = np.empty(Nx.shape[:2] + (3, NNODE))
    BL[:, :, 0] = wx * Nx
    BL[:, :, 1] = wy * Ny
    BL[:, :, 2] = wy * Nx + wx * Ny
    return BL


def btdb_von_karman(K0: Array, B0: Array, Cw: Array, BL: Array) -> Array:
    """``sum_q B^T Cw B`` for ``B = B0 + BL`` (Eq. 3.50's ``(L1 + Lw)^T C (L1 + Lw)``
    with bending; ``Cw = wdet C``) from its linear part ``K0``: with ``BL`` nonzero only in
    the membrane rows and w columns (:func:`von_karman_w_B`),

        B^T Cw B = B0^T Cw B0 + G + G^T + BL^T Cw_mm BL,   G = (BL^T Cw_m) B0,

    where ``_m`` keeps the membrane rows: about a fifth of the products of :func:`btdb`.

    Parameters
    ----------
    K0 : ndarray of shape (E, 45, 45)
        The linear part ``btdb(B0, C, wdet)`` (plus any constant term, e.g. shear).
    B0 : ndarray of shape (E, q, 6, 45)
    Cw : ndarray broadcastable to (E, q, 6, 6)
    BL : ndarray of shape (E, q, 3, 9)

    Returns
    -------
    ndarray of shape (E, 45, 45), a new array.
    """
    E, nq = BL.shape[:2]
    Cw = np.broadcast_to(Cw, (E, nq, 6, 6))
    P = np.matmul(BL.transpose(0, 1, 3, 2), Cw[:, :, :3, :]).transpose(0, 2, 1, 3)  # a,q,j
    G = np.matmul(P.reshape(E, NNODE, nq * 6), B0.reshape(E, nq * 6, NNODE * NDOF))
    H = np.matmul(P[..., :3].reshape(E, NNODE, nq * 3),
                  BL.reshape(E, nq * 3, NNODE))                             # (E, 9, 9)
    Ke = K0.copy()
    K5 = Ke.reshape(E, NNODE, NDOF, NNODE, NDOF)
    G5 = G.reshape(E, NNODE, NNODE, NDOF)                                   # [e, a, b, k]
    K5[:, :, 2, :, :] += G5                                                 # rows (a, w)
    K5[:, :, :, :, 2] += G5.transpose(0, 2, 3, 1)                           # columns (a, w)
    K5[:, :, 2, :, 2] += H
    return Ke


def geometric_kernel(q: Quadrature, N_res: Array) -> Array:
    """Initial-stress (geometric) matrix of the w DOFs, the ``L_w2^T N_E`` term of Eq. (3.52).

    ``Kg_ab = sum_q wdet dN_a^T [[Nxx, Nxy], [Nxy, Nyy]] dN_b``.

    Parameters
    ----------
    N_res : ndarray of shape (E, q, 3)
        Membrane resultants (Nxx, Nyy, Nxy) (N/m), thermal part included.

    Returns
    -------
    ndarray of shape (E, 9, 9)
    """
    Nm = np.empty(N_res.shape[:2] + (2, 2))
    Nm[..., 0, 0] = N_res[..., 0]
    Nm[..., 1, 1] = N_res[..., 1]
    Nm[..., 0, 1] = Nm[..., 1, 0] = N_res[..., 2]
    Nm = Nm * q.wdet[..., None, None]
    tmp = np.matmul(q.dN, Nm)                               # (E, q, 9, 2)
    E, nq = q.dN.shape[:2]
    return np.matmul(tmp.transpose(0, 2, 1, 3).reshape(E, NNODE, nq * 2),
                     q.dN.transpose(0, 1, 3, 2).reshape(E, nq * 2, NNODE))


def mass_kernel(q: Quadrature, I1: Array, I2: Array, I3: Array) -> Array:
    """Consistent element mass ``L0^T I L0`` of Eq. (3.38), shape (E, 45, 45).

    ``I1, I2, I3`` broadcastable to (E, n_qp).
    """
    E, nq = q.wdet.shape
    NN = np.einsum("qa,qb->qab", q.N, q.N)
    m = [np.einsum("eq,qab->eab", np.broadcast_to(Ik, (E, nq)) * q.wdet, NN)
         for Ik in (I1, I2, I3)]
    Me = np.zeros((E, NNODE, NDOF, NNODE, NDOF))
    for k in range(3):
        Me[:, :, k, :, k] = m[0]
    Me[:, :, 0, :, 3] = Me[:, :, 3, :, 0] = m[1]
    Me[:, :, 1, :, 4] = Me[:, :, 4, :, 1] = m[1]
    Me[:, :, 3, :, 3] = Me[:, :, 4, :, 4] = m[2]
    return Me.reshape(E, NNODE * NDOF, NNODE * NDOF)
