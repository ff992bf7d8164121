"""`pipegauge paper` and `pipegauge certificate` through the real command line."""

import json
import subprocess
import sys

import numpy as np
import pytest
from pypdf import PdfReader

from flows.cli import main
from pipeline.camera import sample_certificate_path


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    proc = subprocess.run([sys.executable, "-m", "flows.cli", "paper", "--json", "--out", str(out)],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout), out


@pytest.mark.slow
def test_table1_corner_distortion_and_u95(paper_run):
    result, _ = paper_run
    t1 = result["table1_distortion"]
    assert t1["max_distortion_px"] == pytest.approx(0.05, abs=0.005)
    assert t1["U95_at_max_px"] == pytest.approx(0.001, abs=0.0002)
    for corner in t1["corners"]:
        assert corner["U95_monte_carlo_px"] == pytest.approx(corner["U95_linear_px"], rel=0.05)


@pytest.mark.slow
def test_figure9_follows_eq14(paper_run):
    f9 = paper_run[0]["figure9"]
    H, p_H = f9["H_mm"], f9["p_H_px"]
    uH, up = np.meshgrid(f9["u_H_mm"], f9["u_p_H_px"], indexing="ij")
    expected = np.sqrt(uH**2 / p_H**2 + H**2 * up**2 / p_H**4)
    assert np.array(f9["u_SC_mm_per_px"]) == pytest.approx(expected, rel=1e-12)
    assert f9["range_u_SC_mm_per_px"] == pytest.approx([0.0020004, 0.0282843], rel=1e-4)
    assert f9["SC_mm_per_px"] == pytest.approx(2.0)


@pytest.mark.slow
def test_field_of_view_and_perspective_sweep(paper_run):
    result = paper_run[0]
    fov = result["field_of_view"]
    assert fov["width_mm"] == pytest.approx(974, abs=1.5) and fov["height_mm"] == pytest.approx(731, abs=1.5)
    sweep = result["figure8"]["position_sweep"]
    u95 = [row["U95_X_mm"] for row in sweep]
    assert u95 == sorted(u95)  # more position uncertainty, more U95
    # With u(X0) dominant, U95(X) is close to 1.96 * u * sqrt(1 + 2 (x-x0)^2/f^2).
    last = sweep[-1]
    assert last["U95_X_mm"] == pytest.approx(1.96 * 100 * np.sqrt(1 + 2 * (336.28 / 657.52) ** 2), rel=0.05)


@pytest.mark.slow
def test_files_are_written_and_the_pdf_has_the_figures(paper_run):
    _, out = paper_run
    assert json.loads((out / "paper-reproduction.json").read_text())["certificate_id"] == "PAPER-2020-T1"
    reader = PdfReader(out / "paper-figures.pdf")
    assert len(reader.pages) == 4
    text = " ".join(page.extract_text() for page in reader.pages)
    for heading in ("Figures 6-7", "Figure 8", "Figure 9", "Figure 10"):
        assert heading in text


@pytest.mark.slow
def test_terminal_tables(capsys, tmp_path):
    assert main(["paper", "--no-files"]) == 0
    text = capsys.readouterr().out
    assert "max lens distortion [px]" in text and "Figure 10" in text


def test_certificate_check_exit_codes(capsys, tmp_path):
    cert = str(sample_certificate_path())
    assert main(["certificate", "check", cert]) == 0
    assert "OK" in capsys.readouterr().out
    assert main(["certificate", "check", cert, "--on", "2040-01-01"]) == 1
    assert "expired" in capsys.readouterr().err
    assert main(["certificate", "check", cert, "--image-size", "720x576"]) == 1
    with pytest.raises(SystemExit) as usage:
        main(["certificate", "check", cert, "--image-size", "big"])
    assert usage.value.code == 2


def test_certificate_convert(tmp_path):
    out = tmp_path / "cv.json"
    assert main(["certificate", "convert", str(sample_certificate_path()), "--to", "opencv", "--out", str(out)]) == 0
    assert json.loads(out.read_text())["distortion_convention"] == "opencv"
