"""BDD water level and BAA deformation measured from the image alone, against the synthetic truth."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from pipeline.formats.certificate import load_certificate
from pipeline.domain.records import Observation
from pipeline.vision.contour import detect_contour
from pipeline.vision.contour.deformed_ring import find_deformed_ring
from pipeline.vision.contour.water_line import find_water_line
from pipeline.core.errors import MeasurementError
from pipeline.measurement.automatic import measure_automatic
from pipeline.synth.scene import Deformation, Pipe, Scene
from pipeline.synth.window import render_window

SAMPLES = Path(__file__).resolve().parent.parent / "sample_videos"
H = 300.0


@pytest.fixture(scope="module")
def cert():
    return load_certificate(SAMPLES / "certificates" / "SYN-720x576.json")


def _seen(scene: Scene, cert, z: float, **mount):
    frames, K = render_window(scene, cert, z, **mount)
    return frames, detect_contour([cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in frames], K, "circular")


def _obs(code: str, char1: str = "A") -> Observation:
    return Observation(1, 1.0, code, char1, "", None, "%", None, "", None, None, False, "", None, "", "", {})


@pytest.fixture(scope="module")
def wet(cert):
    return _seen(Scene(Pipe("circular", H, "vitrified clay", 1000.0), water_percent=22.0), cert, 1800.0,
                 offset_mm=(15.0, -25.0), yaw_deg=1.5, pitch_deg=-1.0)


@pytest.fixture(scope="module")
def deformed(cert):
    scene = Scene(Pipe("circular", H, "concrete", 1000.0), features=(Deformation("d", 2600.0, 3600.0, 9.0),))
    return _seen(scene, cert, 3000.0 - 2.5 * H, offset_mm=(0.0, -15.0), pitch_deg=1.0)


@pytest.mark.slow
def test_water_line_is_found_at_the_true_level(wet):
    frames, contour = wet
    line = find_water_line(frames[0], contour.view)
    assert line is not None and line.confident, line
    assert abs(line.level - 0.22) < 0.01
    # both ends of the chord lie on the water line of one cross-section, left and right of the axis
    assert line.a[0] < contour.view.vanishing_point[0] < line.b[0]


def _stained(frame: np.ndarray, view, darker: float) -> np.ndarray:
    """The frame with a band along the wall from 32 to 40 % of the height, its light times ``darker``: two lines
    of the water line's kind (a high-water mark's stain)."""
    from pipeline.vision.contour.water_line import _line_points

    stained = frame.copy()
    depths = np.geomspace(0.8, 5.0, 200)
    for side in (0, 1):
        low, high = _line_points(view, 0.32, depths)[0][side], _line_points(view, 0.40, depths)[0][side]
        band = np.vstack([low, high[::-1]])
        band = band[np.all(np.isfinite(band), axis=1)].round().astype(np.int32)
        shade = np.zeros(frame.shape[:2], np.uint8)
        cv2.fillPoly(shade, [band], 1)
        stained[shade > 0] = (stained[shade > 0] * darker).astype(np.uint8)
    return stained


@pytest.mark.slow
def test_a_water_line_the_overlay_hides_leaves_no_trusted_level(wet):
    """Where the mask hides the wall at the true level (an overlay, or before 2026-12-06 the overlay mask's own
    error), the line found instead (a stain's edge here) is not trusted: the hidden level could not be compared
    with it. Unmasked, the water's line outscores the stain's."""
    from pipeline.vision.contour.water_line import _line_points

    frames, contour = wet
    view, rows_cols = contour.view, frames[0].shape[:2]
    stained = _stained(frames[0], view, 0.75)
    depths = np.geomspace(0.8, 5.0, 200)
    mask = np.full(rows_cols, 255, np.uint8)
    for h in (0.19, 0.22, 0.25):                  # the true level's lines and their neighbours', 12 px wide
        pts, _, _ = _line_points(view, h, depths)
        for side in pts:
            ok = np.all(np.isfinite(side), axis=1)
            cv2.polylines(mask, [side[ok].round().astype(np.int32)], False, 0, thickness=13)
    line = find_water_line(stained, view, mask=mask)
    assert line is not None and 0.30 < line.level < 0.42              # within the stain, the only lines left
    assert not line.confident and any("overlay hides" in p for p in line.problems), line
    clear = find_water_line(stained, view, mask=np.full(rows_cols, 255, np.uint8))
    assert clear is not None and clear.confident and abs(clear.level - 0.22) < 0.01


@pytest.mark.slow
def test_a_water_line_with_a_rival_nearly_as_strong_is_not_trusted(wet):
    """A stain's edge along the wall that stands out nearly as much as the water's line (40 % darker: 21 grey
    levels against 30) leaves the level found untrusted, saying where the rival lies; a fainter stain (25 %
    darker) does not."""
    frames, contour = wet
    unmasked = np.full(frames[0].shape[:2], 255, np.uint8)
    line = find_water_line(_stained(frames[0], contour.view, 0.6), contour.view, mask=unmasked)
    assert line is not None and abs(line.level - 0.22) < 0.01          # the water's line still wins ...
    assert not line.confident, line                                     # ... but not by enough to be trusted
    said = [p for p in line.problems if "another line" in p]
    assert said and any(f"at {pct} % of the height" in said[0] for pct in range(30, 43)), line.problems
    faint = find_water_line(_stained(frames[0], contour.view, 0.75), contour.view, mask=unmasked)
    assert faint is not None and faint.confident and faint.rival > 0.25 * faint.contrast, faint


@pytest.mark.slow
@pytest.mark.parametrize("model", ["perspective", "orthographic"])
def test_water_level_from_the_image_holds_the_truth_in_its_interval(wet, cert, model):
    frames, contour = wet
    q, res = measure_automatic(_obs("BDD"), contour, frames[0], cert, H=H, tolerance=0.0, model=model, seed=3)
    assert q.origin == "water line edge fit" and q.method == "water_level"
    assert res.low <= 22.0 <= res.high, (res.value, res.low, res.high)
    assert res.U95 < 2.0                     # not needlessly wide: a percent or so
    assert any("water line edge fit" in b.description for b in res.budget)


@pytest.mark.slow
def test_deformed_ring_gives_the_vertical_deformation(deformed, cert):
    frames, contour = deformed
    # the pose is fitted to the undeformed rings; the deformed joint's rings are found and left out
    assert any(frame == 0 for frame, _ in contour.deformed)
    assert np.allclose(contour.view.pose[:4], [0.0, -15.0 / H, 0.0, np.radians(1.0)], atol=0.005)
    ring = find_deformed_ring(frames[0], contour)
    assert ring is not None and ring.confident, ring
    assert abs(ring.height - 0.91) < 0.01
    q, res = measure_automatic(_obs("BAA"), contour, frames[0], cert, H=H, tolerance=0.0, model="perspective", seed=4)
    assert q.method == "deformation" and res.low <= 9.0 <= res.high, (res.value, res.low, res.high)
    assert res.confident


@pytest.mark.slow
def test_an_undeformed_joint_is_not_taken_for_a_deformation(cert):
    frames, contour = _seen(Scene(Pipe("circular", H, "concrete", 1000.0)), cert, 1200.0, offset_mm=(0.0, -15.0))
    ring = find_deformed_ring(frames[0], contour)
    assert ring is None or not ring.confident


@pytest.mark.slow
def test_a_dry_pipe_has_no_water_line(cert):
    frames, contour = _seen(Scene(Pipe("circular", H, "concrete", 1000.0)), cert, 1500.0, offset_mm=(10.0, -20.0))
    assert find_water_line(frames[0], contour.view) is None
    with pytest.raises(MeasurementError, match="no water line stands out"):
        measure_automatic(_obs("BDD"), contour, frames[0], cert, H=H, tolerance=0.0, model="perspective", seed=1)


@pytest.mark.slow
@pytest.mark.parametrize("model", ["perspective", "orthographic"])
def test_the_horizontal_dimension_of_the_deformed_ring(deformed, cert, model):
    """The rendered deformation squashes the section to an ellipse of width 1.09 H: BAA B = 100 (1 - 1.09) = -9 %."""
    frames, contour = deformed
    q, res = measure_automatic(_obs("BAA", "B"), contour, frames[0], cert, H=H, tolerance=0.0, model=model, seed=5)
    assert q.method == "deformation_width" and q.anchor is not None
    # one rendered case: an honest 95 % interval misses one case in twenty (this one did by 0.03 % once the pose's
    # covariance stopped being four times too wide, issue 30), so the check is |z| <= 3: it fails for a bias or a
    # u too small, and by chance for one case in 370
    assert abs(res.value + 9.0) <= 3.0 * res.u and res.U95 < 2.0, (res.value, res.u)
    # the anchor on the wall fixes the cross-section's plane: an input of both models (the orthographic one reads
    # its p_H in the plane through it since issue 30's round on levels)
    assert any(b.label == "xo" for b in res.budget)


def test_which_logged_observations_the_image_alone_measures():
    from pipeline.measurement.automatic import measurable_automatically

    assert measurable_automatically(_obs("BDD")) and measurable_automatically(_obs("BAA", "A"))
    assert measurable_automatically(_obs("BAA", "B")) and not measurable_automatically(_obs("BAB", "B"))


@pytest.mark.slow
def test_in_the_night_an_untrusted_result_from_the_image_alone_is_found_not_measured(sample_night):
    """A water level or deformation from the image alone that is not confident is stored as every quantity from the
    image alone is (issue 34): found, not measured, with no value, log check or grade. S01's deformation from the image
    alone lies where its pose is not trusted (no ring seen all round)."""
    from pipeline.store import read_table

    m = read_table(sample_night / "dataset", "measurements")
    auto = m[m.source == "contour"]
    assert (auto[auto.status == "ok"].confident == True).all()  # noqa: E712  (a column of booleans)
    baa = auto[(auto.inspection_id == "S01-circular-clean") & (auto.code == "BAA")].iloc[0]
    assert baa.status == "unmeasured" and baa.error.startswith("found, not measured") and "pose" in baa.error
    assert baa.value is None or np.isnan(baa.value)
    assert baa.log_check in (None, "not checked") or (isinstance(baa.log_check, float) and np.isnan(baa.log_check))
    o = read_table(sample_night / "dataset", "observations")
    row6 = o[(o.inspection_id == "S01-circular-clean") & (o.row == 6)].iloc[0]
    assert row6.grade_source == "Q1 marks"


@pytest.mark.parametrize("size", [(720, 576), (1920, 1080)])
def test_a_rolled_camera_s_water_line_is_found_through_a_larger_camera(size):
    # a circular pipe's rings do not show the camera's roll, so the pose says 0 and the water line lies off its
    # predicted place by the roll, in proportion to the focal length: the search's pixel reach, set on the
    # 720x576 camera, found no line through a 1920x1080 one (S02 in the night: contrast 5 levels against 28)
    from pipeline.synth.samples import sample_certificate
    from pipeline.vision.contour.view import PipeView
    cam = sample_certificate(*size)
    frames, K = render_window(Scene(Pipe("circular", 400.0, "concrete", 2500.0), water_percent=30.0), cam, 1500.0,
                              offset_mm=(35.0, -40.0), yaw_deg=3.0, pitch_deg=2.0, roll_deg=1.5, back_mm=0.0)
    fitted = PipeView("circular", K[0, 0], K[1, 1], K[0, 2], K[1, 2], 35.0 / 400, -40.0 / 400,
                      *np.radians([3.0, 2.0, 0.0]))                 # the roll is not fitted
    line = find_water_line(frames[0], fitted)
    assert line is not None and line.confident, line
    assert abs(line.level - 0.30) < 0.01
