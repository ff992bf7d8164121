"""The U95 a marked extent can reach at a frame, from the marking noise alone, before marking it.

A forward-looking camera on the pipe's axis sees a wall point at depth Z
[mm] (from the camera) at the image radius rho = f R / Z [px] from the
principal point, R = DN / 2 [mm]. Moving a mark by one pixel

* radially (along the image of the axis) moves the point along the pipe by
  dZ = Z^2 / (f R) [mm]: an extent ``along`` the axis (a joint gap, a
  circumferential crack's width, a connection's width along the pipe);
* tangentially (along the image of the cross-section's wall), or within a
  cross-section plane, moves it by Z / f [mm]: an extent ``around`` the
  pipe or in a ``section`` (a longitudinal crack's width, a step, a level).

Two marks, each with standard uncertainty sigma [px] per coordinate, give

    U95(along)  ~ K95 sqrt(2) sigma Z^2 / (f R)
    U95(around) ~ K95 sqrt(2) sigma Z / f

(``predicted_U95``). It leaves out the pose, the certificate and H, so it is
a lower bound of the measured U95; where the marks dominate (small features,
a well-fitted pose) it is close to it (``tests/test_issue30_measurement.py``).
A ``tangent`` extent (the whole distance on the wall) takes the worse, the
axial one. The table in docs/measurement.md is printed by ``python -m
pipeline.measurement.predict``.
"""

from __future__ import annotations

import math

from pipeline.maths.metrology import K95

__all__ = ["predicted_U95", "table"]


def predicted_U95(extent: str, depth_mm: float, dn_mm: float, f_px: float, u_mark_px: float) -> float:
    """U95 [mm] of an extent marked at ``depth_mm`` in a pipe of height ``dn_mm`` (module docstring).

    extent : "along" | "around" | "section" | "tangent"; f_px : focal length [px]; u_mark_px : each mark's
    coordinate u [px]. Raises ValueError for an unknown extent or a non-positive input.
    """
    if min(depth_mm, dn_mm, f_px) <= 0 or u_mark_px < 0:
        raise ValueError(f"depth, DN and f must be > 0 and u >= 0 (got {depth_mm}, {dn_mm}, {f_px}, {u_mark_px})")
    per_px = {"along": depth_mm ** 2 / (f_px * dn_mm / 2.0), "tangent": depth_mm ** 2 / (f_px * dn_mm / 2.0),
              "around": depth_mm / f_px, "section": depth_mm / f_px}
    if extent not in per_px:
        raise ValueError(f"unknown extent {extent!r}; one of {', '.join(per_px)}")
    return K95 * math.sqrt(2.0) * u_mark_px * per_px[extent]


def table(depths_m=(0.3, 0.5, 1.0, 1.5, 2.0, 3.0), dns_mm=(150, 300, 500, 1000), f_px: float = 380.0,
          u_mark_px: float = 0.7) -> str:
    """The predicted U95 [mm] against depth and DN, both extents, as a Markdown table."""
    head = "| extent | DN [mm] | " + " | ".join(f"{d:g} m" for d in depths_m) + " |"
    rows = [head, "|" + "---|" * (len(depths_m) + 2)]
    for extent in ("along", "around"):
        for dn in dns_mm:
            cells = [f"{predicted_U95(extent, 1000.0 * d, dn, f_px, u_mark_px):.3g}" for d in depths_m]
            rows.append(f"| {extent} | {dn} | " + " | ".join(cells) + " |")
    return "\n".join(rows)


if __name__ == "__main__":
    print(table())
