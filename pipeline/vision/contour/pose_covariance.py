"""The pose fit's covariance: cluster-robust (sandwich) with the rings as clusters (docs/contour.md, step 5).

The ring points' reprojection residuals along one ring share that ring's
error (its blur, texture, the wall's own shape there), so the rings, not the
points, are the independent observations. The covariance the data support
is then the cluster-robust one (White's sandwich summed by cluster, with
the CR1 small-sample factor):

    C = A^-1 (sum_k J_k^T r_k r_k^T J_k) A^-1 G / (G - 1),   A = J^T J

over all fitted parameters (pose, one depth per ring), with J_k, r_k the
Jacobian rows and residuals of ring k's points and G the number of rings.
The offset prior's rows enter A (what the prior knows) but no cluster (they
are not data that scatter). Its pose block rests on nu = G - p degrees of
freedom (p fitted pose parameters; ``pose_dof``).

It replaces the residual variance scaled by points per ring, which rested
on the same idea (rings, not points) but stated every pose error about
4 times too large in SD on rendered windows (``benchmarks/pose_coverage.py``).

Units: the pose as ``POSE_PARAMETERS`` ([H, H, rad, rad, rad]); residuals [px].
"""

from __future__ import annotations

import numpy as np

__all__ = ["ring_clustered_covariance", "ring_of_rows"]


def ring_of_rows(jac: np.ndarray, n_pose: int) -> np.ndarray:
    """Ring (cluster) index of each row of the pose fit's Jacobian (M, n_pose + rings), -1 where the row depends
    on no ring's depth (the offset prior's rows; a point whose ray missed the wall, whose row is all zero).

    A ring point's rows depend on its own ring's depth only (``pose_lsq``), so the cluster is read from the
    Jacobian itself and the fit need not carry it.
    """
    depth_cols = np.abs(np.asarray(jac)[:, n_pose:])
    if depth_cols.shape[1] == 0:
        return np.full(len(depth_cols), -1)
    return np.where(depth_cols.max(axis=1) > 0, depth_cols.argmax(axis=1), -1)


def ring_clustered_covariance(jac: np.ndarray, residuals: np.ndarray, n_pose: int) -> np.ndarray:
    """The cluster-robust covariance (n_pose, n_pose) of the pose fitted with one depth per ring.

    jac : Jacobian (M, n_pose + G) at the solution of the plain (not robust) least squares, pose columns first;
    residuals : (M,) [px] there; n_pose : fitted pose parameters.
    Returns the pose block of A^-1 B A^-1 G / (G - 1) (module docstring); inf everywhere when the normal
    matrix is singular or fewer than two rings carry points.
    """
    J = np.asarray(jac, float)
    r = np.asarray(residuals, float)
    cluster = ring_of_rows(J, n_pose)
    used = np.unique(cluster[cluster >= 0])
    G = len(used)
    inf = np.full((n_pose, n_pose), np.inf)
    if G < 2:
        return inf
    try:
        A_inv = np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        return inf
    # each ring's score J_k^T r_k, summed over its rows: one row per ring
    scores = np.zeros((G, J.shape[1]))
    on = cluster >= 0
    np.add.at(scores, np.searchsorted(used, cluster[on]), J[on] * r[on, None])
    B = scores.T @ scores
    C = A_inv @ B @ A_inv * (G / (G - 1.0))
    C = 0.5 * (C + C.T)
    return C[:n_pose, :n_pose]
