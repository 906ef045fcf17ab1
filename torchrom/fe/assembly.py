"""Sparse assembly of element blocks into matrices on the independent (free) DOFs.

On top of scipy.sparse. Element blocks live on the all-grid vector (6 DOFs per grid,
basic axes); the constraint transformation u_all = T u_free (SPC, RBE2, RBE3, automatic SPC, see
:mod:`torchrom.fe.constraints`) gives K_free = Tᵀ K_all T. For matrices assembled many times (the
tangent stiffness) :class:`ProjectedPattern` precomputes, once, where every element entry lands
in the CSR storage of K_free, so that each assembly is one ``numpy.bincount``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def blocks_to_coo(dofs: np.ndarray, blocks: np.ndarray, n: int) -> sp.coo_matrix:
    """Sum of element blocks (E, k, k) on DOF indices (E, k) as an (n, n) COO matrix."""
    k = dofs.shape[1]
    rows = np.repeat(dofs, k, axis=1).reshape(-1)
    cols = np.tile(dofs, (1, k)).reshape(-1)
    return sp.coo_matrix((blocks.reshape(-1), (rows, cols)), shape=(n, n))


def assemble(parts: list[tuple[np.ndarray, np.ndarray]], n: int) -> sp.csr_matrix:
    """Sum several (dofs, blocks) pairs into one CSR matrix on the all-grid vector."""
    out = sp.csr_matrix((n, n))
    for dofs, blocks in parts:
        if len(dofs):
            out = out + blocks_to_coo(dofs, blocks, n).tocsr()
    return out.tocsr()


def project(K_all: sp.spmatrix, T: sp.csr_matrix) -> sp.csr_matrix:
    K = (T.T @ K_all @ T).tocsr()
    K.sum_duplicates()
    return K


class ProjectedPattern:
    """Fixed sparsity pattern of Tᵀ (Σ element blocks) T for blocks on fixed DOFs.

    ``assemble(blocks)`` with blocks (E, k, k) returns the CSR matrix on the free DOFs.
    """

    def __init__(self, dofs: np.ndarray, T: sp.csr_matrix):
        T = T.tocsr()
        E, k = dofs.shape
        self.shape_blocks = (E, k, k)
        rows = np.repeat(dofs, k, axis=1).reshape(-1)
        cols = np.tile(dofs, (1, k)).reshape(-1)
        ip, ix, iv = T.indptr, T.indices, T.data
        nr = ip[rows + 1] - ip[rows]
        nc = ip[cols + 1] - ip[cols]
        m = nr * nc
        entry = np.repeat(np.arange(len(rows)), m)
        start = np.repeat(np.cumsum(m) - m, m)
        offs = np.arange(int(m.sum())) - start
        ncr = np.repeat(nc, m)
        pr = np.repeat(ip[rows], m) + offs // np.maximum(ncr, 1)
        pc = np.repeat(ip[cols], m) + offs % np.maximum(ncr, 1)
        n = T.shape[1]
        key = ix[pr].astype(np.int64) * n + ix[pc]
        uniq, self.slot = np.unique(key, return_inverse=True)
        self.entry = entry
        self.weight = iv[pr] * iv[pc]
        r = uniq // n
        self.indices = (uniq % n).astype(np.int32)
        self.indptr = np.searchsorted(r, np.arange(n + 1)).astype(np.int32)
        self.n = n
        self.nnz = len(uniq)

    def assemble(self, blocks: np.ndarray) -> sp.csr_matrix:
        vals = blocks.reshape(-1)[self.entry] * self.weight
        data = np.bincount(self.slot, weights=vals, minlength=self.nnz)
        shape = (self.n, self.n)
        return sp.csr_matrix((data, self.indices.copy(), self.indptr.copy()), shape=shape)
