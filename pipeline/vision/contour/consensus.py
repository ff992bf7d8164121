"""One video's pose fits checked against one another.

The camera's mount does not move within a few metres, so the poses fitted
from overlapping frame sets (the windows around two observation frames) must
agree. Two checks follow from that:

* **Gross disagreement.** A window whose pose lies far outside the pose of an
  overlapping window that fits its rings better (smaller RMS residual), or
  outside every other trusted window's over the same stretch of pipe
  (``_same_stretch``; at least two, agreeing with each other), is a wrong
  fit (a local minimum of the pose search: offset traded for pitch).
  Its pose is replaced by the better one and flagged, so the result is
  never a confident wrong answer.
* **Reproducibility.** The fit's own covariance (ring-clustered,
  ``pose_covariance``) holds what scatters from ring to ring within a
  window, not what a window's rings share (a mount that moved, a wall off
  its profile over metres). The scatter of the agreeing windows' poses is a
  Type A evaluation of what that misses (JCGM 100 4.2);
  with three or more windows, what it holds beyond the fits' own noise is
  added to each window's covariance. The windows' fit noise is in their
  scatter already, reduced by the frames they share: for windows whose
  estimates correlate by rho (the share of common frames, |A & B| /
  sqrt(|A| |B|), averaged over the pairs) the scatter expected from the fit
  noise alone is (1 - rho) times their mean covariance. Only the positive
  part of the difference is added (issue 30: the full scatter counted the
  fit noise twice). With about three overlapping windows that excess is an
  estimate with about two degrees of freedom (the group's size less one),
  combined with the fit's own by Welch-Satterthwaite (``combined_dof``):
  the contour's ``dof``, which the measurement's t-distributed pose draws use.

Distances are Mahalanobis distances over the fitted pose parameters.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from pipeline.vision.contour.result import PipeContour

__all__ = ["reconcile_windows", "combined_dof", "GROSS_M2", "MIN_OVERLAP"]

# Squared Mahalanobis distance beyond which two fits of overlapping frames cannot both be right
# (a 10-sigma departure); moderate scatter below it goes into the reproducibility term instead.
GROSS_M2 = 100.0
MIN_OVERLAP = 0.5       # share of the smaller window's frames the two windows must have in common


def _fitted(c: PipeContour) -> np.ndarray:
    """Indices of the pose parameters the fit estimated (a parameter held fixed has zero variance)."""
    return np.flatnonzero(np.diag(c.covariance) > 0)


def _m2(a: PipeContour, b: PipeContour) -> float:
    idx = np.intersect1d(_fitted(a), _fitted(b))
    d = (a.view.pose - b.view.pose)[idx]
    C = (a.covariance + b.covariance)[np.ix_(idx, idx)]
    return float(d @ np.linalg.solve(C, d))


def _usable(c: PipeContour) -> bool:
    return c.confident and np.all(np.isfinite(c.covariance)) and len(_fitted(c)) > 0


def reconcile_windows(contours: dict[int, PipeContour], windows: dict[int, list[int]]) -> dict[int, PipeContour]:
    """The contours of one video's observation frames after the two checks of this module.

    contours : frame -> contour fitted from the frames ``windows[frame]`` (frame indices)
    Returns a new mapping; contours without a usable covariance are returned unchanged.
    """
    frames = [f for f in contours if _usable(contours[f])]
    sets = {f: set(windows.get(f, [f])) for f in frames}

    def overlapping(f: int) -> list[int]:
        return [g for g in frames if g != f and _share_frames(sets[f], sets[g])]

    stretch = {f: set(windows.get(f, [f])) for f in contours}

    def alongside(f: int, g: int) -> bool:
        return _same_stretch(stretch[f], stretch[g])

    out = dict(contours)
    replaced = set()
    for f in frames:
        better = [g for g in overlapping(f) if contours[g].rms_px < contours[f].rms_px and _m2(contours[f], contours[g]) > GROSS_M2]
        if better:
            best = min(better, key=lambda g: contours[g].rms_px)
            reason = (f"the pose fitted around frame {f} (RMS {contours[f].rms_px:.2f} px) disagrees grossly with the "
                      f"better fit around frame {best} (RMS {contours[best].rms_px:.2f} px) from overlapping frames; "
                      "that pose is used")
            out[f] = _borrow(contours[f], contours[best], reason, best)
            replaced.add(f)
    # A window alone against every other trusted window over its stretch of pipe (at least two, two of them agreeing
    # with each other) is the wrong one, whatever its RMS: windows that picked none of the same frames are not
    # compared above, and a fit in the offset-for-pitch valley can lie closer to its own rings (S03 through an
    # 800x600 camera: one window 4.6 degrees off the seven others, trusted; benchmarks/night_look.py --poses)
    for f in frames:
        if f in replaced:
            continue
        others = [g for g in frames if g != f and g not in replaced and alongside(f, g)]
        if len(others) >= 2 and all(_m2(contours[f], contours[g]) > GROSS_M2 for g in others) and \
                any(_m2(contours[a], contours[b]) <= GROSS_M2 for i, a in enumerate(others) for b in others[i + 1:]):
            best = min(others, key=lambda g: contours[g].rms_px)
            # ends as the reasons above do: the reports read "that pose is used" as their tail (reports.warning_text)
            reason = (f"the pose fitted around frame {f} disagrees grossly with every other fit over the same stretch "
                      f"of pipe ({len(others)}), the closest to its rings around frame {best}; that pose is used")
            out[f] = _borrow(contours[f], contours[best], reason, best)
            replaced.add(f)
    # A window whose own fit is not trusted takes the pose of a trusted window over its stretch it disagrees with.
    for f in contours:
        if f in frames or not np.all(np.isfinite(contours[f].covariance)) or not len(_fitted(contours[f])):
            continue
        trusted = [g for g in frames if g not in replaced and _m2(contours[f], contours[g]) > GROSS_M2
                   and alongside(f, g)]
        if trusted:
            best = min(trusted, key=lambda g: contours[g].rms_px)
            reason = (f"the pose fitted around frame {f} is not trusted ({'; '.join(contours[f].problems)}) and "
                      f"disagrees with the fit around frame {best} from overlapping frames; that pose is used")
            out[f] = _borrow(contours[f], contours[best], reason, best)
    agreeing = [f for f in frames if f not in replaced]
    for f in agreeing:
        group = [f] + [g for g in overlapping(f) if g not in replaced]
        if len(group) < 3:
            continue
        poses = np.array([contours[g].view.pose for g in group])
        scatter = np.cov(poses.T, ddof=1)
        rho = float(np.mean([len(sets[a] & sets[b]) / np.sqrt(len(sets[a]) * len(sets[b]))
                             for i, a in enumerate(group) for b in group[i + 1:]]))
        within = (1.0 - rho) * np.mean([contours[g].covariance for g in group], axis=0)
        excess = _positive_part(scatter - within)
        held = np.diag(contours[f].covariance) == 0
        excess[held, :] = 0.0
        excess[:, held] = 0.0
        out[f] = dataclasses.replace(contours[f], covariance=contours[f].covariance + excess,
                                     dof=combined_dof(contours[f].covariance, contours[f].dof, excess, len(group) - 1))
    return out


def _share_frames(a: set, b: set) -> bool:
    """Whether two windows (sets of frame indices) share ``MIN_OVERLAP`` of the smaller one's frames."""
    return len(a & b) >= MIN_OVERLAP * min(len(a), len(b))


def _same_stretch(a: set, b: set) -> bool:
    """Whether two windows (sets of frame indices) look at the same stretch of pipe: they share frames
    (``_share_frames``), or their frames' ranges overlap by ``MIN_OVERLAP`` of the shorter range.

    The frames are the first at each 0.1 m of chainage (``window_frames``), so two observation frames a few frames
    apart can pick wholly different frames of the same stretch: S03 through an 800x600 camera, windows 5 frames
    apart sharing none, one fit trusted 4.6 degrees off the other and never compared. What the mount shares is
    the stretch; the frames shared are the fits' correlation (``rho`` below)."""
    if _share_frames(a, b):
        return True
    lo, hi = max(min(a), min(b)), min(max(a), max(b))
    shorter = min(max(a) - min(a), max(b) - min(b))
    return shorter > 0 and hi - lo >= MIN_OVERLAP * shorter


def combined_dof(fit: np.ndarray, nu_fit: float, excess: np.ndarray, nu_excess: float) -> float:
    """Degrees of freedom of fit + excess: Welch-Satterthwaite (GUM G.4.1) on each fitted parameter's variance, the
    smallest over the parameters (the covariance is one estimate; its least-known direction sets nu)."""
    out = float("inf")
    for a, b in zip(np.diag(fit), np.diag(excess)):
        if a + b <= 0:
            continue
        denom = (a**2 / nu_fit if a > 0 else 0.0) + (b**2 / nu_excess if b > 0 else 0.0)
        out = min(out, (a + b) ** 2 / denom if denom > 0 else float("inf"))
    return out


def _positive_part(m: np.ndarray) -> np.ndarray:
    """The symmetric matrix's positive semi-definite part (its negative eigenvalues set to 0)."""
    m = 0.5 * (m + m.T)
    w, v = np.linalg.eigh(m)
    return (v * np.clip(w, 0.0, None)) @ v.T


def _borrow(own: PipeContour, other: PipeContour, reason: str, frame: int) -> PipeContour:
    """``other``'s pose and rings (fitted around ``frame``) for ``own``'s frame, flagged with ``reason``; ``own``'s
    deformed rings stay (they were seen from this frame)."""
    return dataclasses.replace(other, problems=list(other.problems) + [reason], deformed=list(own.deformed),
                               pose_frame=other.pose_frame if other.pose_frame is not None else frame)
