"""Sample planning (Sec. 2.4.5, App. B): OLH plans and smart ordering.

:func:`olh_plan` (scipy.stats.qmc Latin hypercube, centred-discrepancy optimized, through
:func:`hypate.solvers.numerics.random.latin_hypercube`), :func:`smart_order` (kNN graph ->
n_C balanced groups by k-means -> minimum spanning tree per group -> breadth-first order
from the sample nearest to the naive solution; each sample restarts from the nearest sample
computed before it in its group, or from the naive solution; total restart distance
Eq. 2.82) and :func:`write_plan_csv` (the plan for an external CFD campaign).
"""
from __future__ import annotations

import csv
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
from hypate.solvers.aero.base import Array
from hypate.solvers.errors import InputError
from hypate.solvers.numerics.files import atomic_file
from hypate.solvers.numerics.random import as_rng, latin_hypercube
from sklearn.cluster import KMeans
from sklearn.neighbors import kneighbors_graph

__all__ = ["SmartOrder", "olh_plan", "smart_order", "write_plan_csv"]


def olh_plan(bounds: Array, n: int, rng: np.random.Generator | int | None = None) -> Array:
    """Optimal Latin hypercube plan (Sec. 2.4.5; scipy.stats.qmc, centred-discrepancy
    optimized) of ``n`` points in the box ``bounds`` (d, 2)."""
    return latin_hypercube(n, np.asarray(bounds, float), rng, optimization="random-cd")


@dataclass
class SmartOrder:
    """A smart-ordered sample plan (App. B).

    Attributes
    ----------
    group : ndarray of int, shape (N,)
        Group (CPU set) of each sample.
    position : ndarray of int, shape (N,)
        Position of the sample within its group's sequence.
    parent : ndarray of int, shape (N,)
        Sample each one restarts from (-1: the naive solution w_0).
    distance : ndarray of shape (N,)
        d_CFD to the restart solution, Eq. (2.81).
    total_distance : float
        Eq. (2.82) for this ordering.
    naive_distance : float
        Eq. (2.82) when every sample restarts from w_0.
    """

    group: np.ndarray
    position: np.ndarray
    parent: np.ndarray
    distance: np.ndarray
    total_distance: float
    naive_distance: float

    @property
    def ratio(self) -> float:
        """naive_distance / total_distance (> 1: the smart ordering saves)."""
        return self.naive_distance / self.total_distance

    def sequence(self, g: int) -> np.ndarray:
        """Sample indices of group ``g`` in computing order."""
        idx = np.flatnonzero(self.group == g)
        return idx[np.argsort(self.position[idx], kind="stable")]


def _balanced_groups(X: Array, n_groups: int, rng: np.random.Generator) -> Array:
    """Partition into ``n_groups`` equal-sized groups: k-means centroids, then a greedy
    capacity-constrained assignment by increasing distance (a METIS-free graph partition)."""

    N = X.shape[0]
    if n_groups == 1:
        return np.zeros(N, int)
    km = KMeans(n_clusters=n_groups, n_init=10, random_state=int(rng.integers(2**31))).fit(X)
    dist = np.linalg.norm(X[:, None, :] - km.cluster_centers_[None, :, :], axis=2)
    cap = np.full(n_groups, N // n_groups)
    cap[: N % n_groups] += 1
    group = np.full(N, -1)
    for flat in np.argsort(dist, axis=None, kind="stable"):
        i, g = divmod(int(flat), n_groups)
        if group[i] < 0 and cap[g] > 0:
            group[i] = g
            cap[g] -= 1
    return group


def smart_order(samples: Array, naive: Array, n_groups: int = 1,
                scales: Array | None = None, k: int | None = None,
                rng: np.random.Generator | int | None = None) -> SmartOrder:
    """Smart ordering of sample computations (Sec. 2.4.5, App. B).

    Parameters
    ----------
    samples : ndarray of shape (N, d)
        Sample inputs (e.g. [c, a, b]).
    naive : ndarray of shape (d,)
        Inputs of the naive solution w_0 (undeformed panel, mid-range wall temperature).
    n_groups : int
        n_C groups of CPUs computing in parallel.
    scales : ndarray of shape (d,) or None
        Nondimensionalization: d_CFD = ||(x - x*) / scales|| (Eq. 2.81 with D_i = 1/scale_i^2,
        read as a weighted Euclidean distance); default the sample range of each input.
    k : int or None
        Neighbours in the kNN graph; default the smallest k >= 5 making it connected.
    rng : numpy.random.Generator, int or None
        Seed of the k-means partition.
    """

    X = np.asarray(samples, float)
    N, dim = X.shape
    if n_groups < 1 or n_groups > N:
        raise InputError("n_groups", f"must be in [1, {N}]")
    if scales is None:
        scales = np.ptp(X, axis=0)
    scales = np.where(np.asarray(scales, float) > 0, scales, 1.0)
    Z = X / scales
    z0 = np.asarray(naive, float) / scales
    rng = as_rng(rng)
    # step 2: kNN graph, k large enough to be connected
    kk = min(k or 5, N - 1)
    while True:
        G = kneighbors_graph(Z, kk, mode="distance")
        G = G.maximum(G.T)
        if csgraph.connected_components(G, directed=False)[0] == 1 or kk >= N - 1:
            break
        kk = min(2 * kk, N - 1)
    # step 3: equal-sized groups
    group = _balanced_groups(Z, n_groups, rng)
    position = np.zeros(N, int)
    parent = np.full(N, -1)
    distance = np.zeros(N)
    d0 = np.linalg.norm(Z - z0, axis=1)
    for g in range(n_groups):
        idx = np.flatnonzero(group == g)
        sub = G[idx][:, idx]
        # step 4: MST of the group's kNN subgraph (complete graph if the subgraph splits)
        if csgraph.connected_components(sub, directed=False)[0] > 1:
            sub = sp.csr_matrix(np.linalg.norm(Z[idx, None] - Z[None, idx], axis=2))
        T = csgraph.minimum_spanning_tree(sub)
        T = T.maximum(T.T)
        # step 5: breadth-first from the sample nearest to w_0; restart each sample from the
        # nearest solution already computed in its group (its MST parent or better) or w_0
        root = int(np.argmin(d0[idx]))
        order, _ = csgraph.breadth_first_order(T, root, directed=False)
        Zg = Z[idx[order]]
        for pos, local in enumerate(order):
            i = idx[local]
            position[i] = pos
            best, best_d = -1, d0[i]
            if pos:
                dd = np.linalg.norm(Zg[:pos] - Z[i], axis=1)
                j = int(np.argmin(dd))
                if dd[j] < best_d:
                    best, best_d = int(idx[order[j]]), float(dd[j])
            parent[i], distance[i] = best, best_d
    return SmartOrder(group, position, parent, distance, float(distance.sum()),
                      float(d0.sum()))


def write_plan_csv(path: str | Path, samples: Array, order: SmartOrder,
                   names: Sequence[str]) -> None:
    """Export a smart-ordered plan for an external CFD campaign.

    Columns: ``group, position, sample, restart_from`` (-1 = naive solution),
    ``distance`` (Eq. 2.81), then one column per input (``names``). Rows are sorted by group
    and position, i.e. each group's computing order.
    """
    X = np.asarray(samples, float)
    if len(names) != X.shape[1]:
        raise InputError("names", f"need {X.shape[1]} input names")
    rows = sorted(range(X.shape[0]), key=lambda i: (order.group[i], order.position[i]))
    with atomic_file(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["group", "position", "sample", "restart_from", "distance", *names])
        for i in rows:
            w.writerow([int(order.group[i]), int(order.position[i]), i, int(order.parent[i]),
                        f"{order.distance[i]:.6g}", *[f"{v:.10g}" for v in X[i]]])
