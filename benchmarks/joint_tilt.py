"""A joint's ends found with the camera's pose known: how a tilt of the pose moves the gap when the far end shows on
part of its ring only, and where the edges lie at the right pose.

One frame rendered with the pose known (an egg DN600, gap 13 mm, step 9 mm to 9 o'clock, the camera 0.45 m
before the joint, its crown and invert out of the frame; the frame of
``tests/test_joints.py::test_the_gap_s_two_ends_are_read_over_the_same_arc_so_a_tilted_pose_moves_them_alike``),
its ends found with the pose's yaw and pitch moved by up to a degree. For each pose: the gap as the joint finder
reads it (the near end over the far end's arc, ``joint_ends._far_edges``) and with the near end's ring fitted
all around, as before 2026-12-07 (docs/measurement.md, "The gap's two ends over the same arc").

    .venv/bin/python benchmarks/joint_tilt.py        # about 10 s

``--placement``: instead, frames of joints (circular and egg, with and without a step) rendered with the pose
known and found with it: each end's depth error, the gap's and the step's, and the blur the frame's edges tell.
``--plateau N,...`` with it: the same frames with the edges' plateau read within N samples (a quarter pixel each)
of each edge (``joint_ends.LOCAL``, 40 in the night); ``--read-gamma G,...``: read with the grey levels linearised
by the exponent G (``joint_ends.RESPONSE_GAMMA``, 1.35 in the night; 1: the grey levels themselves), to see which
reading a camera's response asks for. ``--clocks``: the same for one circular DN500 joint stepped to
each quarter of the clock, and without its step. ``--blur PX``, ``--groove SHARE``, ``--face GAIN``, ``--gamma G``
and ``--tone-k K`` with either: the frames rendered with that blur, that gap's darkness, that face's brightness or
that response (the display exponent and the logarithmic response's strength; ``Appearance``; a value out of its range
is refused; with the ends apart the far end's face is ``GAIN / 0.8`` times one material's, ``face_albedo``).
``--ends apart`` with either: the pipe ends rendered a gap apart, the far end's face beyond the gap
(``DisplacedJoint.ends``).
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from pathlib import Path

import cv2
import numpy as np

from pipeline.camera.undistort import Undistorter
from pipeline.formats.certificate import load_certificate
from pipeline.measurement.joints import frame_problems
from pipeline.synth.appearance import Appearance
from pipeline.synth.render import Renderer
from pipeline.synth.scene import JOINT_ENDS, DisplacedJoint, Pipe, Scene
from pipeline.vision.contour import joint_ends

sys.path.insert(0, str(Path(__file__).resolve().parent))
from cameras import DEFAULT_CAMERA, true_view  # noqa: E402

H, GAP, STEP, CLOCK, DISTANCE_MM = 600.0, 13.0, 9.0, 9, 450.0
OFFSET_MM, YAW_DEG, PITCH_DEG = (12.8, -8.3), -1.83, -1.45
TILTS_DEG = ((0.0, 0.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0), (0.5, 0.5), (-0.5, -0.5))


# (shape, DN [mm], gap [mm], step [mm], its clock, the camera before the joint [m])
PLACEMENT = (("egg", 500, 15, 12, 12, 0.60), ("egg", 500, 15, 0, 12, 0.60), ("circular", 500, 15, 12, 12, 0.60),
             ("circular", 500, 15, 0, 12, 0.60), ("egg", 600, 13, 9, 9, 0.45), ("circular", 300, 10, 20, 3, 0.30),
             ("circular", 300, 10, 0, 3, 0.30), ("circular", 300, 25, 15, 6, 0.40), ("egg", 400, 20, 15, 3, 0.50),
             ("circular", 800, 20, 30, 12, 1.00))


# ``--placement``'s and ``--clocks``' look: (option, ``Appearance`` field, its range as ``Appearance`` bounds it, what)
LOOK_OPTIONS = (("--blur", "blur_px", "0.3-3 px", "the renderer's blur [px]"),
                ("--groove", "groove", "0.3-1", "the share of light a joint's gap swallows"),
                ("--face", "face_gain", "0.1-2", "the socket's face brightness factor (with --ends apart the far "
                 "end's face GAIN / 0.8 times one material's)"),
                ("--gamma", "gamma", "0.3-1.2", "the display exponent after the logarithmic response"),
                ("--tone-k", "tone_k", "1-200", "the logarithmic response's strength"))


# ``--clocks``: one of them stepped to each quarter, and without its step
CLOCKS = tuple(("circular", 500, 15, step, clock, 0.60) for step, clock in ((12, 12), (12, 3), (12, 6), (12, 9), (0, 12)))


def placement(cert, plateaus: list[int], joints=PLACEMENT, look: Appearance = Appearance(),
              ends: str = "painted", read_gammas: tuple[float, ...] = (joint_ends.RESPONSE_GAMMA,)) -> None:
    """The ``joints``' ends found with the pose known (the camera on the axis, level), per plateau and per exponent
    the grey levels are linearised with (``read_gammas``), rendered with ``look`` and their pipe ends meeting as
    ``ends`` says (``DisplacedJoint.ends``)."""
    und = Undistorter(cert, cert.image_width_px, cert.image_height_px)
    K = und.K
    frames = []
    for shape, h, gap, step, clock, dist in joints:
        scene = Scene(Pipe(shape, float(h), "concrete", 2000.0),
                      features=(DisplacedJoint("j", 1, float(gap), float(step), clock=clock, ends=ends),))
        frames.append(cv2.cvtColor(und.frame(Renderer(scene, cert, seed=3, appearance=look).render(2000.0 - 1000.0 * dist)),
                                   cv2.COLOR_BGR2GRAY))
    kept = joint_ends.LOCAL, joint_ends.RESPONSE_GAMMA
    print("| plateau [samples] | read at | shape | DN | gap, step [mm] | its clock | camera before it [m] | near end's error [mm] "
          "| far end's [mm] | gap's [mm] | step's [mm] | blur read [px] | the frame in the night |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    try:
        for local, gamma in itertools.product(plateaus, read_gammas):
            joint_ends.LOCAL, joint_ends.RESPONSE_GAMMA = local, gamma
            errors = []
            for (shape, h, gap, step, clock, dist), gray in zip(joints, frames):
                view = true_view(shape, K, h)
                e = joint_ends.find_joint_ends(gray, view, 1000.0 * dist / h)
                near, far = (1000.0 * dist - gap / 2) / h, (1000.0 * dist + gap / 2) / h
                if e is None:
                    print(f"| {local} | {gamma:g} | {shape} | {h} | {gap}, {step} | {clock} | {dist:.2f} | not found "
                          "| | | | | |")
                    continue
                errors.append((e.far_depth - e.near_depth) * h - gap)
                print(f"| {local} | {gamma:g} | {shape} | {h} | {gap}, {step} | {clock} | {dist:.2f} | {(e.near_depth - near) * h:+.2f} "
                      f"| {(e.far_depth - far) * h:+.2f} | {errors[-1]:+.2f} | {np.hypot(*e.step) * h - step:+.2f} "
                      f"| {e.blur_px:.2f} | {_frame_verdict(e, view)} |")
            print(f"| {local} | {gamma:g} | all | | | | | | | rms {math.sqrt(np.mean(np.square(errors))):.2f} | | | |")
    finally:
        joint_ends.LOCAL, joint_ends.RESPONSE_GAMMA = kept


def _frame_verdict(e: joint_ends.JointEnds, view) -> str:
    """What the night's rules for one frame (``joints.frame_problems``) say of its gap (A) and its step (B): "A, B
    read", or which is held and why (the first problem, shortened)."""
    why = {q: frame_problems(e, q, view) for q in "AB"}
    if not why["B"]:
        return "A, B read"
    held = why["A"] or why["B"]
    reason = held[0] if len(held[0]) <= 60 else held[0][:57] + "..."
    return f"{'A, B' if why['A'] else 'B'} held: {reason}" + ("" if why["A"] else "; A read")


def _windows(text: str) -> list[int]:
    """``--plateau``'s windows: whole numbers of samples, 4 to 400, comma-separated."""
    try:
        windows = [int(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give whole numbers of samples, comma-separated (e.g. 40,20,16)") \
            from None
    if not all(4 <= w <= 400 for w in windows):
        raise argparse.ArgumentTypeError(f"{text!r}: each window is 4 to 400 samples (a quarter pixel each)")
    return windows


def _exponents(text: str) -> list[float]:
    """``--read-gamma``'s exponents: numbers from 0.5 to 4, comma-separated."""
    try:
        exponents = [float(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give numbers, comma-separated (e.g. 1,1.35,1.8)") from None
    if not all(0.5 <= g <= 4.0 for g in exponents):
        raise argparse.ArgumentTypeError(f"{text!r}: each exponent is 0.5 to 4")
    return exponents


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--placement", action="store_true", help="where the edges lie with the pose known, not the tilt")
    ap.add_argument("--clocks", action="store_true",
                    help="with the pose known, one circular joint stepped to 12, 3, 6 and 9 o'clock and without a step")
    for flag, field, bounds, what in LOOK_OPTIONS:
        ap.add_argument(flag, dest=field, metavar=flag[2:].upper().replace("-", "_"), type=float,
                        default=getattr(Appearance(), field),
                        help=f"with --placement or --clocks: {what} ({bounds}; default the look's "
                        f"{getattr(Appearance(), field):.3g})")
    ap.add_argument("--ends", choices=JOINT_ENDS, default="painted",
                    help="with --placement or --clocks: how the pipe ends meet (painted: the generator's band at the "
                    "joint's plane, the step's face inside it; apart: a gap apart, the far end's face beyond the gap)")
    ap.add_argument("--plateau", type=_windows, default=[joint_ends.LOCAL],
                    help="with --placement: the edges' plateau windows to try [samples, comma-separated]")
    ap.add_argument("--read-gamma", type=_exponents, default=[joint_ends.RESPONSE_GAMMA],
                    help="with --placement: the exponents to linearise the grey levels with before the edges are "
                    f"read (1: the grey levels themselves; the night's {joint_ends.RESPONSE_GAMMA:g}) [comma-separated]")
    args = ap.parse_args()
    cert = load_certificate(DEFAULT_CAMERA)
    if args.placement or args.clocks:
        try:
            look = Appearance(**{field: getattr(args, field) for _, field, _, _ in LOOK_OPTIONS})
        except ValueError as exc:
            ap.error(f"{exc} ({', '.join(f'{flag} {bounds}' for flag, _, bounds, _ in LOOK_OPTIONS)})")
        placement(cert, args.plateau, CLOCKS if args.clocks else PLACEMENT, look, args.ends, tuple(args.read_gamma))
        return
    scene = Scene(Pipe("egg", H, "concrete", 2000.0), features=(DisplacedJoint("j", 1, GAP, STEP, clock=CLOCK),))
    und = Undistorter(cert, cert.image_width_px, cert.image_height_px)
    frame = Renderer(scene, cert, offset_mm=OFFSET_MM, yaw=math.radians(YAW_DEG), pitch=math.radians(PITCH_DEG),
                     seed=3).render(2000.0 - DISTANCE_MM)
    gray = cv2.cvtColor(und.frame(frame), cv2.COLOR_BGR2GRAY)
    K = und.K
    print("| the pose's yaw, pitch off by [deg] | gap error, near end over the far end's arc [mm] "
          "| near end all around [mm] |")
    print("|---|---|---|")
    for d_yaw, d_pitch in TILTS_DEG:
        view = true_view("egg", K, H, OFFSET_MM, YAW_DEG + d_yaw, PITCH_DEG + d_pitch)
        e = joint_ends.find_joint_ends(gray, view, DISTANCE_MM / H)
        if e is None:
            print(f"| {d_yaw:+.1f}, {d_pitch:+.1f} | not found | not found |")
            continue
        (t_all, *_), _ = joint_ends._fit_ring(view, e.near_px, e.near_depth, joint_ends._radius_of("egg"))
        print(f"| {d_yaw:+.1f}, {d_pitch:+.1f} | {(e.far_depth - e.near_depth) * H - GAP:+.2f} "
              f"| {(e.far_depth - t_all) * H - GAP:+.2f} |")


if __name__ == "__main__":
    main()
