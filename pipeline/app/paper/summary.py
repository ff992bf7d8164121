"""Terminal summary of the paper reproduction: the paper's numbers beside ours."""

from __future__ import annotations

from typing import Any

from pipeline.core.text import format_table

__all__ = ["summary_text"]


def summary_text(result: dict[str, Any]) -> str:
    """Tables of the reproduced results, from the dict of ``reproduce``."""
    stated = result["paper_stated"]
    t1, fov = result["table1_distortion"], result["field_of_view"]
    ortho = result["orthographic_scenario"]
    worst = max(t1["corners"], key=lambda c: c["distortion_px"])
    blocks = [format_table(
        ("quantity", "paper", "pipegauge", "how"),
        [
            ("max lens distortion [px]", f"{stated['max_distortion_px']:.3f}", f"{t1['max_distortion_px']:.4f}",
             f"eqs. 16-19 at ({t1['at_px'][0]:.0f}, {t1['at_px'][1]:.0f}) px"),
            ("U95 of max distortion [px]", f"{stated['U95_max_distortion_px']:.3f}",
             f"{worst['U95_linear_px']:.5f} / {worst['U95_monte_carlo_px']:.5f}",
             f"linear k=1.96 / Monte Carlo {worst['trials']} trials"),
            ("field of view at 1 m [mm]", "{:.0f} x {:.0f}".format(*stated["field_of_view_mm"]),
             f"{fov['width_mm']:.1f} x {fov['height_mm']:.1f}",
             "eqs. 1-11; {:.1f} x {:.1f} with f = 4.27 mm".format(
                 fov["with_f_rounded_to_4.27_mm"]["width_mm"], fov["with_f_rounded_to_4.27_mm"]["height_mm"])),
            ("SC for H=1000 mm, p_H=500 px [mm/px]", f"{stated['SC_mm_per_px']:.2f}", f"{ortho['SC_mm_per_px']:.2f}", "eq. 12"),
        ],
        title="Source paper against pipegauge (Martins, Almeida, Ribeiro, ACTA IMEKO 2020)",
    )]

    blocks.append(format_table(
        ("corner (x, y) [px]", "|d| [px]", "U95 linear", "U95 MC", "MC trials", "largest share of u^2"),
        [(f"({c['x_px']:.0f}, {c['y_px']:.0f})", f"{c['distortion_px']:.4f}", f"{c['U95_linear_px']:.5f}",
          f"{c['U95_monte_carlo_px']:.5f}", c["trials"],
          "{} {:.0%}".format(*max(c["budget_share"].items(), key=lambda kv: kv[1])))
         for c in t1["corners"]],
        title="Figures 6-7: distortion of the Table 1 camera at the image corners",
    ))

    f8 = result["figure8"]
    rows = [(f"u(pos) = {r['u_position_mm']:g} mm, u(xy) = {r['u_image_px']:g} px", f"{r['U95_X_mm']:.2f}",
             f"{r['U95_Y_mm']:.2f}", f"{r['relative_U95_X_percent']:.2f}", f"{r['relative_U95_Y_percent']:.2f}", r["trials"])
            for r in f8["position_sweep"] + f8["image_sweep"]]
    blocks.append(format_table(
        ("inputs", "U95(X) [mm]", "U95(Y) [mm]", "U95(X)/FOV [%]", "U95(Y)/FOV [%]", "MC trials"), rows,
        title=f"Figure 8: perspective model at image point ({f8['point_px'][0]:.0f}, {f8['point_px'][1]:.0f}) px, "
              f"Z = 1000 mm (adaptive Monte Carlo)",
    ))

    f9 = result["figure9"]
    show = [i for i, v in enumerate(f9["u_p_H_px"]) if v in (0.01, 0.1, 1, 5)]
    rows = [(f"{uh:g}",) + tuple(f"{f9['u_SC_mm_per_px'][i][j]:.5f}" for j in show) for i, uh in enumerate(f9["u_H_mm"])]
    blocks.append(format_table(
        ("u(H) [mm]",) + tuple(f"u(p_H)={f9['u_p_H_px'][j]:g} px" for j in show), rows,
        title=f"Figure 9: u(SC) [mm/px] by eq. 14, H = {f9['H_mm']:g} mm, p_H = {f9['p_H_px']:g} px "
              f"(range {f9['range_u_SC_mm_per_px'][0]:.4f} to {f9['range_u_SC_mm_per_px'][1]:.4f})",
    ))
    blocks.append(format_table(
        ("u(H) [mm]", "u(p_H) [px]", "eq. 14", "engine linear", "Monte Carlo", "d_low", "d_high", "delta", "linear validated"),
        [(f"{c['u_H_mm']:g}", f"{c['u_p_H_px']:g}", f"{c['u_SC_eq14']:.6f}", f"{c['u_SC_linear']:.6f}",
          f"{c['u_SC_monte_carlo']:.6f}", f"{c['d_low']:.1e}", f"{c['d_high']:.1e}", f"{c['delta']:.0e}",
          "yes" if c["validated"] else "no") for c in f9["checks"]],
        title="Figure 9 checks: eq. 14 against the GUM engine (JCGM 101 clause 8)",
    ))

    f10 = result["figure10"]
    xs = f10["X_mm"]
    pick = [xs.index(v) for v in (10.0, 50.0, 100.0, 200.0) if v in xs]
    rows = [(f"{c['u_H_mm']:g}", f"{c['u_p_H_px']:g}") + tuple(f"{c['relative_U95_percent'][j]:.3f}" for j in pick)
            for c in f10["cases"]]
    blocks.append(format_table(
        ("u(H) [mm]", "u(p_H)=u(p_X) [px]") + tuple(f"X={xs[j]:g} mm" for j in pick), rows,
        title="Figure 10: relative U95 of X [%] by eqs. 14-15 (U95 = 1.96 u)",
    ))
    blocks.append(f"seed {result['seed']}; certificate {result['certificate_id']}; pipegauge {result['pipegauge_version']}")
    return "\n\n".join(blocks)
