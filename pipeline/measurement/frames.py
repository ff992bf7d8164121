"""One quantity marked on several frames, combined with the inputs the frames share counted once.

A feature marked on n frames gives n values y_i = f_i(S, X_i), each the
frame's own model (``quantity._frame_model``, the one ``measure_quantity``
uses) of the inputs S it shares with the other frames and its own inputs
X_i. Shared, drawn once for all frames:

* ``H``, the header's height: one pipe;
* ``certificate``, the relative scale error from the camera's parameters:
  one camera. Its u differs a little between frames (it depends on where
  the marks lie in the image); the draws are taken as fully correlated,
  frame i's factor being 1 + (c - 1) u_i / u_max (the pessimistic choice:
  it does not average down);
* ``wall_x``, ``wall_y``, the pipe's shift under the feature (a displaced
  joint before it): one pipe, handled as the certificate;
* ``edge``, an image fit's definition of the feature's edges (where its
  edge level lies against the true end: the camera's response, the blur, the
  ends' shape), the same in every frame of one feature (``MarkedQuantity.u_edge``,
  the joints' ``edge_u``); handled as the certificate: frame i's separation
  of a and b moves by x u_i / u_max, so it does not shrink by sqrt(n) over
  the frames as each frame's own points do;
* the camera pose, where frames' contours come from one pose fit (the same
  ``PipeContour`` object, or the same pose and covariance); otherwise each
  frame has its own, labelled with its frames (``ox@f1234``).

The marks (``xa``, ``ya``, ``xb``, ``yb``, the anchor; with ``p_H`` and
``approximation`` for the orthographic model) are each frame's own and carry
its label: ``xa@f1234``.

The combined value is the weighted mean

    y = sum_i w_i y_i,  w_i = (1 / v_i) / sum_j (1 / v_j),

where v_i is frame i's variance from its inputs not common to every frame
(linearised at the estimates; the weights are then fixed). Why not the
whole variance: an input common to every frame moves every y_i alike, so
it does not average down, and with frame covariance D + s 1 1' (D the
frames' own variances, s the common part) the minimum-variance weights are
D^-1 1 / (1' D^-1 1): the common part drops out of them (Sherman-Morrison).
Weighting by the whole variance would pull a sharp near frame towards a
poor far one whenever the common part dominates.

The uncertainty is not computed from the weights: the law of propagation
and the adaptive Monte Carlo run on the combined model over the union of
the inputs, so a shared input is drawn once per trial for all frames, and
the interval, U95, class-edge shares, resolution flag, confidence and
reasons follow ``quantity._result``, the rules of ``measure_quantity``.
With one view the result is ``measure_quantity``'s.

Left as independent between frames: the orthographic model's ``p_H`` (each
frame's own plane; with one pose fit their errors are correlated, so the
orthographic combination of such frames understates u: prefer the
perspective model, whose pose is shared explicitly).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
import scipy.special

from pipeline.camera import Certificate
from pipeline.maths.metrology import InputSet, JointNormal, Normal, propagate_linear
from pipeline.measurement.quantity import (POSE_LABELS, SHARED_LABELS, MarkedQuantity, QuantityResult, _across_line,
                                           _frame_model, _FrameModel, _measure_frame, _result)
from pipeline.vision.contour import PipeContour

__all__ = ["measure_over_frames", "frame_weights", "frame_values", "frame_covariance", "chi_square_with_covariance",
           "beyond_agreement"]


def _same_pose(a: PipeContour, b: PipeContour) -> bool:
    return a is b or (np.array_equal(a.view.pose, b.view.pose) and np.array_equal(a.covariance, b.covariance))


def _pose_groups(contours: Sequence[PipeContour]) -> list[int]:
    """Index of each frame's pose group: frames whose contours come from one pose fit share one."""
    firsts: list[int] = []
    group = []
    for i, c in enumerate(contours):
        g = next((k for k, j in enumerate(firsts) if _same_pose(contours[j], c)), None)
        if g is None:
            firsts.append(i)
            g = len(firsts) - 1
        group.append(g)
    return group


def _shared(built: list[_FrameModel], views: Sequence[tuple[MarkedQuantity, PipeContour]]) -> tuple[set[str], bool]:
    """What every view shares: the ``SHARED_LABELS`` all their models hold, and whether one pose fit is theirs."""
    common = {label for label in SHARED_LABELS if all(label in f.independent for f in built)}
    return common, max(_pose_groups([c for _, c in views])) == 0


def _common(frames: list[_FrameModel], label: str):
    """The one distribution of a shared input, and each frame's map from its draw to the frame's own value.

    Equal distributions are one input. Normal ones differing in u (the certificate's, the wall's) become one draw
    standardised to the widest: frame i reads m_i + (x - m) u_i / u, fully correlated.
    """
    items = [f.independent[label] for f in frames]
    if all(item == items[0] for item in items):
        return items[0], [None] * len(frames)
    if not all(isinstance(item, Normal) for item in items):
        raise ValueError(f"input {label!r} differs between the frames and is not normal: {items}")
    widest = max(items, key=lambda d: d.u)
    maps = [None if d == widest else (d.x, widest.x, d.u / widest.u) for d in items]
    return widest, maps


def _linearised(frame: _FrameModel) -> tuple[np.ndarray, np.ndarray]:
    """The frame's sensitivities to its uncertain inputs and their covariance, in the order of its inputs' labels."""
    inputs = frame.inputs
    lin = propagate_linear(frame.fn, inputs, name="y")
    return np.array([line.sensitivity for line in lin.budget]), inputs.covariance()


def _own_variance(frame: _FrameModel, common: set[str]) -> float:
    """Frame's variance [unit^2] from its inputs not common to every frame, linearised at the estimates."""
    c, cov = _linearised(frame)
    own = np.array([label not in common for label in frame.inputs.labels])
    c = np.where(own, c, 0.0)
    return float(c @ cov @ c)


def frame_weights(variances: Sequence[float]) -> np.ndarray:
    """Weights [1] of the frames' values from their own (not common) variances: inverse variance, summing to 1.

    A frame with zero own variance takes all the weight (shared with others at zero)."""
    v = np.asarray(variances, float)
    if np.any(v <= 0):
        w = (v <= 0).astype(float)
    else:
        w = 1.0 / v
    return w / w.sum()


def measure_over_frames(views: Sequence[tuple[MarkedQuantity, PipeContour]], cert: Certificate, *, H: float,
                        tolerance: float, model: str = "perspective", seed: int = 1, edges: tuple[float, ...] = (),
                        frames: Sequence[int] | None = None, monte_carlo: bool = True) -> QuantityResult:
    """One quantity marked on several frames, combined with the shared inputs counted once (module docstring).

    views : (marked quantity, its frame's pipe contour) per frame, the same code, quantity and method in each
    H, tolerance : the header's nominal height and the half-width of its tolerance [mm]
    seed, edges : as ``measure_quantity``
    frames : frame numbers naming the frames' own inputs in the budget (``xa@f1234``); 1, 2, ... by default
    monte_carlo : False: the law of propagation only, as ``measure_quantity``'s preview (``pipegauge review``)
    Raises ValueError for no view or views of different quantities, MeasurementError as ``measure_quantity``.
    """
    views = list(views)
    if not views:
        raise ValueError("measure_over_frames needs at least one (marked quantity, contour) view")
    kinds = {(q.code, q.char1, q.quantity, q.method) for q, _ in views}
    if len(kinds) > 1:
        raise ValueError(f"the views mark different quantities {sorted(kinds)}; combine views of one quantity only")
    numbers = list(range(1, len(views) + 1)) if frames is None else [int(f) for f in frames]
    if len(numbers) != len(views) or len(set(numbers)) != len(numbers):
        raise ValueError(f"frames must give one distinct number per view ({len(views)} views, frames {numbers})")
    built = [_frame_model(q, c, cert, H=H, tolerance=tolerance, model=model, seed=seed) for q, c in views]
    tags = [f"f{n}" for n in numbers]
    if len(built) == 1:
        return _measure_frame(built[0], seed, edges, monte_carlo)

    group = _pose_groups([c for _, c in views])
    pose_tag = ["+".join(t for t, g in zip(tags, group) if g == k) for k in range(max(group) + 1)]
    common, shared_pose = _shared(built, views)
    if shared_pose:
        common |= set(POSE_LABELS)

    # the union of the inputs, each frame's labels renamed, and its map from the union's draws to its own
    independent: dict = {}
    joint: list[JointNormal] = []
    renames: list[dict[str, str]] = []
    maps: list[dict[str, tuple[float, float, float]]] = [{} for _ in built]
    seen_groups: set[int] = set()
    for i, f in enumerate(built):
        rename = {}
        for label, item in f.independent.items():
            if label in common and label not in POSE_LABELS:
                rename[label] = label
            elif label in POSE_LABELS:      # a pose held fixed (zero variance in the fit): a constant of its group
                rename[label] = label if shared_pose else f"{label}@{pose_tag[group[i]]}"
                if group[i] not in seen_groups:
                    independent[rename[label]] = item
            else:
                rename[label] = f"{label}@{tags[i]}"
                independent[rename[label]] = item
        for g in f.joint:
            names = [label if shared_pose else f"{label}@{pose_tag[group[i]]}" for label in g.labels]
            rename.update(zip(g.labels, names))
            if group[i] not in seen_groups:
                joint.append(JointNormal(names, g.x, g.cov, dof=g.dof))
        seen_groups.add(group[i])
        renames.append(rename)
    for label in sorted(common - set(POSE_LABELS), key=SHARED_LABELS.index):
        item, frame_maps = _common(built, label)
        independent[label] = item
        for i, m in enumerate(frame_maps):
            if m is not None:
                maps[i][label] = m
    inputs = InputSet(independent, joint=joint)

    weights = frame_weights([_own_variance(f, common) for f in built])

    def over_frames(**values):
        total = 0.0
        for f, w, rename, m in zip(built, weights, renames, maps):
            own = {}
            for local, name in rename.items():
                x = values[name]
                if local in m:
                    x_i, x_ref, ratio = m[local]
                    x = x_i + (x - x_ref) * ratio
                own[local] = x
            total = total + w * np.asarray(f.fn(**own), float)
        return total

    main = built[int(np.argmax(weights))]
    reasons = [f"{tag}: {r}" for f, tag in zip(built, tags) for r in f.plane.reasons]
    model_reasons = [f"{tag}: {r}" for f, tag in zip(built, tags) for r in f.model_reasons]
    # the budget's words for a label's frames: "xa@f1234" is "..., frame 1234"; "yaw@f1+f2" "..., frames 1, 2"
    words = {tag: f"frame {n}" for tag, n in zip(tags, numbers)}
    words.update({t: "frames " + ", ".join(x[1:] for x in t.split("+")) for t in pose_tag if "+" in t})
    nuisance = [_across_line(*f.nuisance, model, label=f"across@{tag}", where=f", {words[tag]}")
                for f, tag in zip(built, tags) if f.nuisance is not None]
    return _result(over_frames, inputs,
                   value_at_estimates=float(np.dot(weights, [f.value for f in built])),
                   v_ortho=float(np.dot(weights, [f.v_ortho for f in built])),
                   v_persp=float(np.dot(weights, [f.v_persp for f in built])),
                   reasons=reasons, model_reasons=model_reasons, main=main,
                   # resolved when one frame resolves it: the combination then says more than an upper bound
                   p_X=max(f.p_X for f in built),
                   confident=all(f.plane.confident and f.contour.confident for f in built),
                   nuisance_lines=nuisance, seed=seed, edges=edges, suffixes=words, monte_carlo=monte_carlo)


def frame_values(views: Sequence[tuple[MarkedQuantity, PipeContour]], cert: Certificate, *, H: float,
                 tolerance: float, model: str = "perspective", seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Each view's own value [unit] and its standard uncertainty [unit] from the inputs not common to every view,
    the inputs ``measure_over_frames`` weights the views by. (Whether the views agree: ``frame_covariance``, as
    what the views share moves them alike only where they are equally sensitive to it.)
    """
    views = list(views)
    built = [_frame_model(q, c, cert, H=H, tolerance=tolerance, model=model, seed=seed) for q, c in views]
    common, shared_pose = _shared(built, views)
    if shared_pose:
        common |= set(POSE_LABELS)
    own = [_own_variance(f, common) for f in built]
    return np.array([f.value for f in built], float), np.sqrt(np.maximum(own, 0.0))


def frame_covariance(views: Sequence[tuple[MarkedQuantity, PipeContour]], cert: Certificate, *, H: float,
                     tolerance: float, model: str = "perspective", seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Each view's own value [unit] and the covariance of the views' values [unit^2], linearised at the estimates.

    What the views share moves them alike only where each view is equally sensitive to it. A pose fit shared by
    frames at different depths is not: an error in the camera's offset or tilt moves a near frame's value more than
    a far one's, so it spreads the views apart. Diagonal: each view's whole variance; off the diagonal, the
    inputs the views share: the pose of one fit (its covariance), and ``SHARED_LABELS`` drawn fully correlated as
    ``measure_over_frames`` draws them (frame i's draw scaled to its own u). Where every view is equally sensitive
    to the shared inputs, the chi-square about the mean (``chi_square_with_covariance``) is the one from the
    views' own u alone (``frame_values``): their common part drops out of it.
    """
    views = list(views)
    built = [_frame_model(q, c, cert, H=H, tolerance=tolerance, model=model, seed=seed) for q, c in views]
    common, shared_pose = _shared(built, views)
    n = len(built)
    cov = np.zeros((n, n))
    standardised = []    # per view: label -> sensitivity x u of each shared input drawn fully correlated
    pose = []            # per view: the sensitivities to the pose's labels, and their covariance
    for i, f in enumerate(built):
        labels = f.inputs.labels
        c, full = _linearised(f)
        cov[i, i] = float(c @ full @ c)
        u = np.sqrt(np.diag(full))
        standardised.append({lab: c[k] * u[k] for k, lab in enumerate(labels) if lab in common})
        at = [k for k, lab in enumerate(labels) if lab in POSE_LABELS] if shared_pose else []
        pose.append((c[at], full[np.ix_(at, at)]))
    for i in range(n):
        for j in range(i + 1, n):
            s = sum(standardised[i][lab] * standardised[j].get(lab, 0.0) for lab in standardised[i])
            (ci, sigma), (cj, _) = pose[i], pose[j]
            if len(ci) and len(ci) == len(cj):
                s += float(ci @ sigma @ cj)
            cov[i, j] = cov[j, i] = s
    return np.array([f.value for f in built], float), cov


def chi_square_with_covariance(values: Sequence[float], cov: np.ndarray) -> float:
    """The chi-square of ``values`` about their generalised least-squares mean, with their covariance ``cov``
    (``frame_covariance``): r' V^-1 r, r = y - m 1, m = 1' V^-1 y / 1' V^-1 1; n - 1 degrees of freedom.
    nan for fewer than two values, a value not finite or a covariance not positive definite."""
    y = np.asarray(values, float)
    V = np.asarray(cov, float)
    if len(y) < 2 or not np.all(np.isfinite(y)) or not np.all(np.isfinite(V)):
        return float("nan")
    try:
        L = np.linalg.cholesky(V)
    except np.linalg.LinAlgError:
        return float("nan")
    ones = np.ones_like(y)
    wy, w1 = np.linalg.solve(L, y), np.linalg.solve(L, ones)
    m = float(w1 @ wy / (w1 @ w1))
    r = wy - m * w1
    return float(r @ r)


def beyond_agreement(chi2: float, n: int, p_min: float = 0.01) -> bool:
    """Whether ``chi2`` of n views (``chi_square_with_covariance``) lies beyond its 1 - ``p_min`` point for n - 1
    degrees of freedom: the views disagree. False for a chi-square not finite (fewer than two values)."""
    # the point from scipy.special, not scipy.stats: the latter costs a second at start-up
    return math.isfinite(chi2) and chi2 > scipy.special.chdtri(n - 1, p_min)
