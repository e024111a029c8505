"""The skin mesh of seed 002 (Eqs. 1-2): which taxels are neighbours, and how far apart."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import Delaunay

from .model import Layout


@dataclass
class SkinMesh:
    """Taxel graph of a layout.

    positions : (N, 3) metres. normals : (N, 3) unit.
    triangles : (F, 3) int, taxel indices.
    adjacency : (N, N) CSR, 1.0 where two taxels share a mesh edge (E of seed 002, Eq. 1).
    distances : (N, N) CSR, Euclidean edge length in metres on the same pattern (D, Eq. 2).
    """

    positions: np.ndarray
    normals: np.ndarray
    triangles: np.ndarray
    adjacency: sp.csr_matrix
    distances: sp.csr_matrix

    @property
    def edges(self) -> np.ndarray:
        """(M, 2) int, each undirected edge once with i < j."""
        coo = sp.triu(self.adjacency, k=1).tocoo()
        return np.column_stack([coo.row, coo.col]).astype(np.int64)

    def __len__(self) -> int:
        return len(self.positions)


def mesh_from_triangles(positions, normals, triangles) -> SkinMesh:
    """Build E and D (CSR, symmetric) from a triangle list over ``positions`` (N, 3)."""
    positions = np.asarray(positions, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    n = len(positions)
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e = np.sort(e, axis=1)
    e = np.unique(e[e[:, 0] != e[:, 1]], axis=0)
    i = np.concatenate([e[:, 0], e[:, 1]])
    j = np.concatenate([e[:, 1], e[:, 0]])
    length = np.linalg.norm(positions[i] - positions[j], axis=1)
    adj = sp.csr_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
    dist = sp.csr_matrix((length, (i, j)), shape=(n, n))
    return SkinMesh(positions, np.asarray(normals, dtype=np.float64), tri, adj, dist)


def skin_mesh(layout: Layout) -> SkinMesh:
    """The skin mesh of ``layout``: Delaunay triangulation of its flat patch coordinates."""
    if layout.flat is None:
        raise ValueError("skin_mesh needs flat coordinates for now")
    tri = Delaunay(layout.flat).simplices if len(layout) >= 3 else np.zeros((0, 3), int)
    return mesh_from_triangles(layout.positions, layout.normals, tri)
