"""The method statement printed in every condition report (our own text; reportlab paragraph markup)."""

from __future__ import annotations

__all__ = ["method_statement", "VALIDATION"]

# From `measurement_coverage.py --cache` then `coverage_stats.py` (the commands in docs/measurement.md, "all" rows,
# 2026-12-02, with the pose's ring-clustered covariance and the Monte Carlo to the digits printed); update both
# together when the benchmark is rerun.
VALIDATION = ("Validation against synthetic ground truth (docs/measurement.md): the true value lay inside the "
              "reported 95 % interval for 96.4 % of 221 quantities (perspective model) and 98.4 % of 125 "
              "(orthographic).")


def method_statement(model: str | None) -> list[str]:
    """Paragraphs saying how the numbers were obtained, for the given measurement model."""
    common = [
        "Source: Martins, Almeida and Ribeiro, <i>Optical metrology applied in CCTV inspection in drain and sewer "
        "systems</i>, ACTA IMEKO 9(1), 2020. Uncertainty per JCGM 100 (GUM) and JCGM 101 (Monte Carlo).",
        "Chainage: read from the video's overlay by OCR and fitted as a monotone track over time; the frame of each "
        "observation is the one the contractor marked. Marked points are undistorted with the camera's calibration "
        "certificate (Brown model, eqs. 16-19). The pipe contour (camera pose in the pipe) is fitted to the joint "
        "rings of the frames around the observation; p_H is the pixel height of the cross-section through the marked "
        "points, with u(p_H) from the fit's covariance and the wall's tolerance (and the step of a displaced joint "
        "logged before it).",
        "Each quantity is measured along its own extent: a longitudinal crack's width and a connection's height "
        "around the pipe, a circumferential crack's width, a connection's width and a joint gap along its axis; "
        "the marks' separation across that extent is listed in the budget (<i>across</i>) but is no part of the "
        "value. Intervals stay within what the quantity can be (a width is never negative); a feature spanning "
        "under 2 px in the image is given as its upper bound (below resolution), and an interval lying unevenly "
        "about the value as [low, high].",
        "Quantities marked \"from the image alone\" were measured without the contractor's marks: the water level "
        "(BDD) from the water line found along the wall with the fitted pose, a deformation (BAA, vertical or "
        "horizontal) from a joint ring inside the deformed stretch; the points found stand in for marks, with their "
        "uncertainty from the image fit.",
    ]
    if model == "orthographic":
        specific = [
            "Orthographic model (eqs. 12-15): SC = H / p_H, X = SC · p_X. Uncertainty by the law of propagation "
            "(k = 1.96), accepted only when a Monte Carlo run agrees within the numerical tolerance (JCGM 101 "
            "clause 8); otherwise the Monte Carlo interval is reported. The model's own approximation error "
            "(orthographic against perspective at the estimates) enters the budget as the input <i>approximation</i>."]
    else:
        specific = [
            "Perspective model (collinearity, eqs. 1-11): each marked point's ray is cast from the fitted camera pose "
            "to the pipe wall or to the cross-section plane of its companion point; the quantity follows from the "
            "3-D points. Uncertainty by adaptive Monte Carlo (JCGM 101 7.9) over H, the camera pose (joint normal "
            "from the fit), the marks, the certificate and the wall tolerance; the reported interval is the shortest "
            "95 % interval and U95 its largest distance from the value. Seeds are fixed per quantity, so a re-run "
            "repeats every trial."]
    budget = ["Budgets list each input's estimate, standard uncertainty, distribution and sensitivity c_i "
              "(linearised model) and its contribution |c_i| u(x_i), to compare with the combined standard "
              "uncertainty u_c."]
    return common + specific + budget + [VALIDATION]
