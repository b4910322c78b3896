"""The peer of `resound bench modal --peer`.

Solves the generalized eigenproblem K x = lambda M x that `bench-case --export` wrote
(Matrix Market, SI units) with scipy's ARPACK (`eigsh`) in shift-invert mode. The shifted
matrix K - sigma M is factored by CHOLMOD (scikit-sparse) when it is installed, else by
scipy's SuperLU. Reading the files is not timed; the factorization and the eigen-solve are.

Usage: modal_peer.py DIR K SIGMA  ->  one JSON line on stdout.
"""
import json
import resource
import sys
import time

import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as sla


def main() -> None:
    folder, k, sigma = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
    stiffness = sp.csc_matrix(scipy.io.mmread(f"{folder}/K.mtx"))
    mass = sp.csc_matrix(scipy.io.mmread(f"{folder}/M.mtx"))
    t0 = time.perf_counter()
    shifted = (stiffness - sigma * mass).tocsc()
    try:
        from sksparse.cholmod import cholesky

        factor = cholesky(shifted)
        solve = factor
        solver = "cholmod"
    except ImportError:
        lu = sla.splu(shifted)
        solve = lu.solve
        solver = "superlu"
    factor_s = time.perf_counter() - t0
    op = sla.LinearOperator(shifted.shape, matvec=solve, dtype=np.float64)
    values = sla.eigsh(
        stiffness, k=k, M=mass, sigma=sigma, which="LM", OPinv=op, return_eigenvectors=False
    )
    total_s = time.perf_counter() - t0
    lam = np.sort(values)
    freqs = np.sqrt(np.maximum(lam, 0.0)) / (2.0 * np.pi)
    print(
        json.dumps(
            {
                "solver": f"scipy {scipy.__version__} eigsh + {solver}",
                "factor_s": factor_s,
                "total_s": total_s,
                "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
                "freqs_hz": freqs.tolist(),
            }
        )
    )


if __name__ == "__main__":
    main()
