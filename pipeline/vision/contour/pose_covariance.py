"""The pose fit's covariance: cluster-robust (sandwich) with the rings as clusters (docs/contour.md, step 5).

The ring points' reprojection residuals along one ring share that ring's
error (its blur, texture, the wall's own shape there), so the rings, not the
points, are the independent observations. The covariance the data support
is then the cluster-robust one, White's sandwich summed by cluster:

    C_CR1 = A^-1 (sum_k J_k^T r_k r_k^T J_k) A^-1 G / (G - 1),   A = J^T J

over all fitted parameters (pose, one depth per ring), with J_k, r_k the
Jacobian rows and residuals of ring k's points and G the number of rings.
With about 20 rings of very unequal weight (the near rings fix most of the
pose) CR1 understates: on rendered windows its z had a robust SD of 1.1-1.4.
So the pose block is its leave-one-ring-out form (CR3, the jackknife;
Cameron and Miller 2015, "A practitioner's guide to cluster-robust
inference", section VI), exact for the linearised fit:

    C = (G - 1) / G sum_k d_k d_k^T,   d_k = (A_p - A_p,k)^-1 s_k

where each ring's pose columns have its own depth column projected out
(J~_k: its depth is its own, so leaving the ring out leaves its depth out),
A_p,k = J~_k^T J~_k, A_p = sum_k A_p,k + the prior's information, and
s_k = J~_k^T r_k; d_k is how far the pose moves when ring k is left out.
The offset prior's rows enter A_p (what the prior knows) but no cluster
(they are not data that scatter). C rests on nu = G - p degrees of freedom
(p fitted pose parameters; ``pose_dof``).

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
    """The cluster-robust covariance (n_pose, n_pose) of the pose fitted with one depth per ring: the
    leave-one-ring-out jackknife (CR3, module docstring).

    jac : Jacobian (M, n_pose + G) at the solution of the plain (not robust) least squares, pose columns first;
    residuals : (M,) [px] there (either sign); n_pose : fitted pose parameters.
    Returns inf everywhere when fewer than two rings carry points or the pose is not determined without one of
    them (the fit then rests on that ring alone).
    """
    J = np.asarray(jac, float)
    r = np.asarray(residuals, float)
    cluster = ring_of_rows(J, n_pose)
    used = np.unique(cluster[cluster >= 0])
    G = len(used)
    inf = np.full((n_pose, n_pose), np.inf)
    if G < 2:
        return inf
    pose = J[:, :n_pose]
    # each ring's pose columns with its own depth profiled out (the depth is the ring's alone), its
    # information and its score
    infos, scores = [], []
    for k in used:
        rows = cluster == k
        d = J[rows, n_pose + k]
        Jk = pose[rows] - np.outer(d, d @ pose[rows] / (d @ d))
        infos.append(Jk.T @ Jk)
        scores.append(Jk.T @ r[rows])
    rest = cluster < 0                 # the offset prior's rows: information, no cluster
    A = np.sum(infos, axis=0) + pose[rest].T @ pose[rest]
    V = np.zeros((n_pose, n_pose))
    try:
        for info, score in zip(infos, scores):
            step = np.linalg.solve(A - info, score)      # the pose's move when ring k is left out (linear model)
            V += np.outer(step, step)
    except np.linalg.LinAlgError:
        return inf
    if not np.all(np.isfinite(V)):
        return inf
    return V * (G - 1.0) / G
