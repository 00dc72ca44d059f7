"""The annihilator Delta°_Q(q) = range A(q)^T of the constraint distribution, (26)/(27) of
Leok & Ohsawa, as the Dirac checks use it (principle stage): how far a covector is from it,
the part of (32)/(33) that a multiplier is free to absorb.
"""

import numpy as np


def distance_to_range(B, x, tol_rank):
    """max-norm of x (k,) minus its least-squares projection on the column space of B
    (k, m), singular values below `tol_rank` times the largest cut; |x| when m = 0."""
    if B.size == 0:
        return float(np.abs(x).max())
    coeff, *_ = np.linalg.lstsq(B, x, rcond=tol_rank)
    return float(np.abs(x - B @ coeff).max())
