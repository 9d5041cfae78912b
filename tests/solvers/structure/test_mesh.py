"""Structured 9-node meshes and the DCS9 shape functions."""
from __future__ import annotations

import numpy as np
import pytest
from hypate.solvers.errors import InputError
from hypate.solvers.materials import isotropic
from hypate.solvers.panel import Layer, PanelSpec
from hypate.solvers.structure.element import Quadrature, gauss_rule, shape_functions
from hypate.solvers.structure.mesh import panel_mesh, shell_mesh


def test_grid_contract_and_node_sets():
    m = shell_mesh(2.0, 1.0, 4, 3)
    ni, nj = 9, 7
    assert m.n_nodes == ni * nj and m.n_elem == 12 and m.elements.shape == (12, 9)
    i, j = 5, 4
    nid = j * ni + i                                    # the shared grid contract
    assert m.node_id(i, j) == nid
    np.testing.assert_allclose(m.coords[nid], [i * 2.0 / 8, j * 1.0 / 6])
    np.testing.assert_allclose(m.x[m.edges["x0"]], 0.0)
    np.testing.assert_allclose(m.x[m.edges["xa"]], 2.0)
    np.testing.assert_allclose(m.y[m.edges["y0"]], 0.0)
    np.testing.assert_allclose(m.y[m.edges["yb"]], 1.0)
    np.testing.assert_allclose(m.coords[m.center], [1.0, 0.5])
    assert m.boundary_nodes.size == 2 * ni + 2 * nj - 4
    # every node used; element e = ej nx + ei, local node 3 s + r at (2 ei + r, 2 ej + s)
    assert np.unique(m.elements).size == m.n_nodes
    e = 1 * 4 + 2
    np.testing.assert_array_equal(m.elements[e, [0, 2, 8]],
                                  [m.node_id(4, 2), m.node_id(6, 2), m.node_id(6, 4)])


def test_elements_have_positive_area_and_tile_the_panel():
    m = shell_mesh(0.7, 0.3, 5, 2)
    q = Quadrature.on(m.coords[m.elements], 3)
    assert np.all(q.wdet > 0)
    assert q.wdet.sum() == pytest.approx(0.7 * 0.3, rel=1e-13)


def test_shape_functions_partition_of_unity_and_kronecker():
    r = np.tile(np.arange(3), 3) - 1.0
    s = np.repeat(np.arange(3), 3) - 1.0
    N, dN = shape_functions(r, s)
    np.testing.assert_allclose(N, np.eye(9), atol=1e-15)
    pts, w = gauss_rule(3)
    N, dN = shape_functions(pts[:, 0], pts[:, 1])
    np.testing.assert_allclose(N.sum(axis=1), 1.0, rtol=1e-14)
    np.testing.assert_allclose(dN.sum(axis=1), 0.0, atol=1e-14)
    # reproduces x^2 y^2 exactly (biquadratic)
    f = (r**2) * (s**2)
    np.testing.assert_allclose(N @ f, pts[:, 0] ** 2 * pts[:, 1] ** 2, atol=1e-14)


def test_2d_panel_is_one_element_across_and_bad_input():
    mat = isotropic("m", 1.0, 1.0, 0.3, 0.0, 1.0, 1.0)
    panel = PanelSpec(layers=(Layer(mat, 0.01),), kind="2d", mesh=(6, 4))
    m = panel_mesh(panel)
    assert (m.nx, m.ny) == (6, 1)
    with pytest.raises(InputError):
        shell_mesh(1.0, 1.0, 0, 2)
    with pytest.raises(InputError):
        shell_mesh(-1.0, 1.0, 2, 2)
