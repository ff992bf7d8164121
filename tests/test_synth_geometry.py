"""The renderer's geometry against OpenCV's camera model, through a real encoded video."""

import math

import cv2
import numpy as np
import pytest

from pipeline.maths.profiles import clock_to_theta, wall_point
from pipeline.synth.render import LIP_MM, Renderer
from pipeline.camera.pose import CameraPose, project_points
from pipeline.synth.samples import sample_certificate
from pipeline.synth.scene import Marker, Pipe, Scene


def encode_and_decode(frames, path):
    """Frames through a real mp4v file and back, as every later stage will see them."""
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 25.0, (w, h))
    assert writer.isOpened()
    for f in frames:
        writer.write(f)
    writer.release()
    cap = cv2.VideoCapture(str(path))
    out = []
    while True:
        ok, f = cap.read()
        if not ok:
            break
        out.append(f)
    assert len(out) == len(frames)
    return out


MARKERS = [Marker(600.0, c, 3.0) for c in (1, 3, 5, 7, 9, 11)] + [Marker(900.0, c, 4.0) for c in (2, 4, 8, 10, 12)]


@pytest.mark.slow
@pytest.mark.parametrize("shape", ["circular", "egg"])
def test_wall_points_appear_where_opencv_projects_them(tmp_path, shape):
    cert = sample_certificate(720, 576)
    pipe = Pipe(shape, 450.0, "plastic", 3000.0)
    mount = dict(offset_mm=(25.0, -30.0), yaw=math.radians(2.0), pitch=math.radians(1.5), roll=math.radians(1.0))
    with_markers = Renderer(Scene(pipe, features=tuple(MARKERS)), cert, noise=0.0, **mount)
    without = Renderer(Scene(pipe), cert, noise=0.0, **mount)
    z_cam = 200.0
    # Each frame in its own file, so both are key frames and neither is predicted from the other.
    frames = [encode_and_decode([with_markers.render(z_cam)], tmp_path / "a.mp4")[0],
              encode_and_decode([without.render(z_cam)], tmp_path / "b.mp4")[0]]
    diff = cv2.absdiff(frames[0], frames[1]).max(axis=2).astype(np.float32)

    pose = CameraPose(25.0, -30.0, z_cam, mount["yaw"], mount["pitch"], mount["roll"])
    world = np.array([[*wall_point(shape, 450.0, clock_to_theta(m.clock)), m.z_mm] for m in MARKERS])
    expected = project_points(world, pose, cert)
    errors = []
    for (x, y) in expected:
        x0, y0 = int(round(x)), int(round(y))
        win = diff[y0 - 8:y0 + 9, x0 - 8:x0 + 9].copy()
        win[win < 0.25 * win.max()] = 0           # keep the marker, drop compression ripples
        ys, xs = np.mgrid[y0 - 8:y0 + 9, x0 - 8:x0 + 9]
        cx, cy = (win * xs).sum() / win.sum(), (win * ys).sum() / win.sum()
        errors.append(math.hypot(cx - x, cy - y))
    assert max(errors) < 0.5, f"marker position errors [px]: {np.round(errors, 3)}"


@pytest.mark.slow
def test_joint_ring_radius_is_f_R_over_d(tmp_path):
    """The bright ring of a joint (the socket's end face, lit head-on) has radius f R / d in the ideal image."""
    cert = sample_certificate(720, 576)
    R, L, gap = 200.0, 1000.0, 10.0
    renderer = Renderer(Scene(Pipe("circular", 2 * R, "plastic", L, joint_gap_mm=gap)), cert, noise=0.0)
    K, dist = cert.camera_matrix(), cert.opencv_distortion()
    f, cx, cy = cert.focal_px[0], cert.value("cx"), cert.value("cy")
    checks = []
    for d_joint in (900.0, 1400.0, 2000.0):
        frame = encode_and_decode([renderer.render(L - d_joint)], tmp_path / f"r{d_joint:.0f}.mp4")[0]
        ideal = cv2.undistort(frame, K, dist).astype(np.float32).mean(axis=2)
        d = d_joint - gap / 2 - LIP_MM / 2          # the face's centre plane, just before the gap
        expected = f * R / d
        radii = np.arange(expected - 8, expected + 8, 0.05)
        angles = np.linspace(0, 2 * np.pi, 720, endpoint=False)
        map_x = (cx + radii[:, None] * np.cos(angles)[None, :]).astype(np.float32)
        map_y = (cy + radii[:, None] * np.sin(angles)[None, :]).astype(np.float32)
        profile = cv2.remap(ideal, map_x, map_y, cv2.INTER_LINEAR).mean(axis=1)
        # Brightness above the wall's smooth trend (fitted away from the ring) marks the face.
        outside = np.abs(radii - expected) > 5
        trend = np.polyval(np.polyfit(radii[outside], profile[outside], 2), radii)
        excess = np.clip(profile - trend, 0, None) * (np.abs(radii - expected) < 5)
        measured = float((excess * radii).sum() / excess.sum())
        checks.append((d, expected, measured))
    for d, expected, measured in checks:
        assert measured == pytest.approx(expected, abs=0.5), f"d = {d} mm: f R / d = {expected:.2f} px, ring at {measured:.2f} px"


@pytest.mark.slow
def test_a_joint_inside_a_deformed_stretch_is_drawn_deformed_also_when_it_is_displaced():
    """The wall positions follow the deformation whatever else changes the rays (here a displaced joint's segments)."""
    from pipeline.vision.contour.ridges import dark_centre, ridge_points
    from pipeline.synth.scene import Deformation, DisplacedJoint
    from pipeline.camera.undistort import Undistorter

    cert = sample_certificate(720, 576)
    R, e, z_cam = 150.0, 0.08, 1700.0
    scene = Scene(Pipe("circular", 2 * R, "concrete", 2500.0), features=(
        Deformation("d", 2200.0, 2600.0, 100 * e), DisplacedJoint("j", 1, 20.0, 10.0, clock=6)))
    und = Undistorter(cert, 720, 576)
    gray = cv2.cvtColor(und.frame(Renderer(scene, cert, offset_mm=(0.0, -10.0)).render(z_cam)), cv2.COLOR_BGR2GRAY)
    pts, _, _ = ridge_points(gray, dark_centre(gray))
    K, th = und.K, np.linspace(0, 2 * np.pi, 721)

    def near(a, b, z):      # ridge points within 1.5 px of the section (half-axes a, b; invert in place) at z
        X, Y = a * np.cos(th), -R + b + b * np.sin(th) + 10.0
        P = np.c_[K[0, 0] * X / (z - z_cam) + K[0, 2], -K[1, 1] * Y / (z - z_cam) + K[1, 2]]
        return int((np.min(np.linalg.norm(pts[:, None] - P[None], axis=2), axis=1) < 1.5).sum())

    z = 2490.0        # the socket face before joint 1, inside the deformed stretch
    assert near(R * (1 + e), R * (1 - e), z) > 3 * near(R, R, z)


def test_a_stop_with_a_reversal_backs_up_and_drives_on():
    from pipeline.synth.trajectory import Stop, travel

    plain, plain_spans = travel(0.0, 2.0, 0.1, [Stop(1.0, 1.0)], 25.0)
    back, spans = travel(0.0, 2.0, 0.1, [Stop(1.0, 1.0, back_m=0.3)], 25.0)
    assert spans == plain_spans                           # the halt's frames, where the observation's marks are
    first, last = spans[0]
    after = back[last + 1:]
    turn = int(np.argmin(after))
    assert after[turn] == pytest.approx(0.7, abs=0.005)   # backed up 0.3 m
    assert np.all(np.diff(after[:turn + 1]) < 0) and np.all(np.diff(after[turn:]) >= 0)
    assert len(back) > len(plain) and back[-1] == pytest.approx(plain[-1])


def test_a_look_changes_how_the_pipe_looks_not_where():
    """The look (``synth.appearance``) blurs, darkens corners and joints, but moves no wall point: the same scene
    under two looks has its joint ring in the same place, and each part of the look does what it says."""
    from pipeline.synth.appearance import Appearance, varied_appearance

    cert = sample_certificate(320, 256)
    scene = Scene(Pipe("circular", 300.0, "concrete", 1000.0, joint_gap_mm=20.0))

    def frame(**look):
        return cv2.cvtColor(Renderer(scene, cert, noise=0.0, appearance=Appearance(**look)).render(400.0),
                            cv2.COLOR_BGR2GRAY).astype(float)

    plain, sharp, blurred = frame(), frame(blur_px=0.5), frame(blur_px=2.0)
    energy = [float(np.mean(np.abs(np.diff(f, axis=1)))) for f in (sharp, plain, blurred)]
    assert energy[0] > energy[1] > energy[2]
    vignetted = frame(vignette=0.4)
    corner, centre = (slice(0, 40), slice(0, 40)), (slice(108, 148), slice(140, 180))
    assert vignetted[corner].mean() < 0.95 * plain[corner].mean()     # light lost before the log response
    assert abs(vignetted[centre].mean() - plain[centre].mean()) < 0.03 * plain[centre].mean() + 1.0
    # the joint's gap: darker with a deeper groove, at the same place (the darkest ring's row along the centre)
    shallow, deep = frame(groove=0.5), frame(groove=0.95)
    column = shallow.shape[1] // 2
    gap_rows = np.argsort(deep[:, column] - shallow[:, column])[:3]
    assert np.all(deep[gap_rows, column] < shallow[gap_rows, column] - 2)
    assert np.argmin(deep[:60, column]) == np.argmin(shallow[:60, column])
    rng = np.random.default_rng(0)
    for _ in range(20):
        varied_appearance(rng)                     # always inside the ranges Appearance accepts
    with pytest.raises(ValueError, match="blur_px"):
        Appearance(blur_px=0.0)
