"""Reference kernels of the HTSH thermal element (Sec. 4.2): the 8-node hexahedron and its
4-node faces at 2-point Gauss points (Eq. 4.18), and the rotation of the orthotropic
conductivity from material to panel axes (Eq. 4.2)."""
from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

#: Gauss point coordinate of the 2-point rule (all Gauss weights are 1).
GAUSS_POINT = 1.0 / math.sqrt(3.0)


def hex_reference() -> tuple[Array, Array]:
    """Shape functions N (n_qp=8, 8) and derivatives dN/deta (8, 8, 3) at 2x2x2 Gauss points.

    Local node ``a = i + 2 j + 4 k`` (i, j, k in {0, 1}) has
    ``N_a = f_i(eta1) f_j(eta2) f_k(eta3)``, ``f_0 = (1 - eta) / 2``, ``f_1 = (1 + eta) / 2``
    (Eq. 4.18); the Gauss points use the same ordering with ``eta = -+1/sqrt(3)``.
    """
    signs = np.array([[i, j, k] for k in (0, 1) for j in (0, 1) for i in (0, 1)], float)
    s = 2.0 * signs - 1.0  # node sign per axis, (8, 3)
    eta = GAUSS_POINT * s  # Gauss points, (8, 3)
    f = 0.5 * (1.0 + eta[:, None, :] * s[None, :, :])  # (q, a, d)
    N = np.prod(f, axis=2)
    dN = np.empty((8, 8, 3))
    for d in range(3):  # three axes, not elements
        others = [o for o in range(3) if o != d]
        dN[:, :, d] = 0.5 * s[None, :, d] * f[:, :, others[0]] * f[:, :, others[1]]
    return N, dN


def quad_reference() -> Array:
    """Bilinear shape functions N (n_qp=4, 4) at 2x2 Gauss points (x fastest, then y)."""
    s = np.array([[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0], [1.0, 1.0]])
    eta = GAUSS_POINT * s
    f = 0.5 * (1.0 + eta[:, None, :] * s[None, :, :])
    return np.prod(f, axis=2)


def rotate_conductivity(kd: Array, c: float, s: float) -> Array:
    """Material-axes diagonal [k1, k2, k3] -> panel-axes [k_xx, k_yy, k_xy, k_zz] (Eq. 4.2).

    Parameters
    ----------
    kd : ndarray of shape (..., 3)
        Principal conductivities (W/(m K)).
    c, s : float
        Cosine and sine of the layer angle.

    Returns
    -------
    ndarray of shape (..., 4)
    """
    k1, k2, k3 = kd[..., 0], kd[..., 1], kd[..., 2]
    if c == 1.0 and s == 0.0:
        # an unrotated layer (the usual case, every thermal residual): k1 c^2 + k2 s^2 is k1
        # exactly, and (k1 - k2) c s is zero
        out = np.empty(kd.shape[:-1] + (4,))
        out[..., 0], out[..., 1], out[..., 2], out[..., 3] = k1, k2, 0.0, k3
        return out
    return np.stack([k1 * c * c + k2 * s * s, k1 * s * s + k2 * c * c, (k1 - k2) * c * s, k3],
                    axis=-1)
