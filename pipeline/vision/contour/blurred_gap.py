"""A dark gap seen through a blur: how wide it reads at half levels, and the width it had.

A gap of width w between two bright plateaus, blurred by a Gaussian of standard deviation sigma (the lens, the
sensor, the codec), has its floor raised once w is not large against sigma: the profile no longer reaches the
gap's own level. Read where the profile crosses half-way between that raised floor and each plateau (as
``joint_ends`` reads a joint's edges), the gap comes out wider than it is: by 0.03 sigma at w = 5 sigma, 0.11
sigma at 4 sigma, 0.33 sigma at 3 sigma, and never under 2.355 sigma (the blur's own full width at half maximum)
however narrow the gap. With the profile scaled to its own contrast, the reading depends on w / sigma alone::

    I(x) = 1 - [Phi((x + w/2) / sigma) - Phi((x - w/2) / sigma)]          (plateaus 1, gap 0)
    floor = I(0) = 2 - 2 Phi(w / (2 sigma))
    width read: 2 x_c, where I(x_c) = (floor + 1) / 2

and so does the width of each edge's ramp, from a quarter to three quarters of the way from floor to plateau:
1.349 sigma (an edge's own) for a wide gap, 0.907 sigma for one far under the blur. Their ratio, ramp over
width read, is a function of w / sigma alone (0.385 for a gap under the blur, falling as 1.349 sigma / w for a wide
one): it gives w / sigma where the gap is at least about 2.5 sigma wide (``RHO_INFORMATIVE``), and with the width
read, sigma. Crossings, not slopes: a slope read over a pixel about the edge is bent by the profile's own
curvature there (sigma 4 % high at w = 3 sigma), a crossing is not. The blur is one for the frame (one lens, one
focus, one codec), so a frame's sigma is the median over its generators', and each generator's width is then
read back through it (``unblurred_width``).

>>> round(float(half_level_width(4.0)), 3), round(float(half_level_width(8.0)), 3)
(4.114, 8.0)
>>> round(float(unblurred_width(4.114, 1.0)), 2)
4.0
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr

__all__ = ["EDGE_RAMP", "FWHM", "RHO_INFORMATIVE", "half_level_width", "unblurred_width", "blur_from_edges", "width_per_sigma"]

FWHM = 2.0 * np.sqrt(2.0 * np.log(2.0))     # the width [sigma] a gap far under the blur reads: the blur's own


def _crossings(a: np.ndarray, frac: float) -> np.ndarray:
    """Where [sigma, from the gap's centre] the blurred gap of half width a [sigma] crosses ``frac`` of the way
    from its floor to the plateau (bisection: the dip falls monotonically outward)."""
    level = (2.0 * ndtr(a) - 1.0) * (1.0 - frac)                # the dip's depth there
    lo, hi = np.zeros_like(a), a + 8.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        deeper = ndtr(mid + a) - ndtr(mid - a) > level
        lo, hi = np.where(deeper, mid, lo), np.where(deeper, hi, mid)
    return 0.5 * (lo + hi)


_A = np.linspace(1e-4, 6.0, 1200)                              # half the gap [sigma]
_W, _READ = 2.0 * _A, 2.0 * _crossings(_A, 0.5)                 # the gap, the width read at half levels [sigma]
_RAMP = _crossings(_A, 0.75) - _crossings(_A, 0.25)             # an edge's ramp, a quarter to three quarters [sigma]
_RHO = _RAMP / _READ                                            # falls with w / sigma
EDGE_RAMP = float(_RAMP[-1])                                    # a single edge's ramp [sigma]: 1.349
RHO_INFORMATIVE = float(np.interp(2.5, _W, _RHO))              # ramp / width above this (w under 2.5 sigma): too flat
                                                                # in w / sigma to give sigma


def half_level_width(w_over_sigma):
    """The width a gap w / sigma wide reads at half levels [sigma]."""
    return np.interp(w_over_sigma, _W, _READ, right=np.nan)


def unblurred_width(width_px, sigma_px):
    """The gap's width [px] from the width read at half levels [px] through a blur sigma [px]; 0 where the width
    read is under the blur's own (the gap is not resolved), the width read itself beyond the table (w > 12 sigma,
    where the two agree to 1e-5 sigma)."""
    r = np.asarray(width_px, float) / sigma_px
    w = np.interp(r, _READ, _W, left=0.0) * sigma_px
    return np.where(r > _READ[-1], width_px, w)


def width_per_sigma(width_px, sigma_px, d: float = 0.01):
    """d(width)/d(sigma) at a fixed width read [px per px]: how an error of the blur moves the width found."""
    return (unblurred_width(width_px, sigma_px * (1 + d)) - unblurred_width(width_px, sigma_px * (1 - d))) \
        / (2 * d * sigma_px)


def blur_from_edges(width_px, ramp_px):
    """The blur sigma [px] that reads a gap ``width_px`` wide at half levels with edges whose ramps (a quarter to
    three quarters of the way from floor to plateau) are ``ramp_px`` wide [px]; nan where the pair does not tell
    (ramp over width above ``RHO_INFORMATIVE``: a gap under about 2.5 sigma)."""
    width = np.asarray(width_px, float)
    rho = np.asarray(ramp_px, float) / np.where(width > 0, width, np.nan)
    r = np.interp(rho, _RHO[::-1], _READ[::-1])                # width read [sigma] for that ratio
    wide = rho < _RHO[-1]                                       # beyond the table: an edge's own ramp, 1.349 sigma
    sigma = np.where(wide, np.asarray(ramp_px, float) / _RAMP[-1], width / r)
    return np.where(rho <= RHO_INFORMATIVE, sigma, np.nan)
