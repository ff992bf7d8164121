"""What pipegauge reads in one video or image: the chainage overlay, its track, the pipe contour (``pipegauge probe``).

Returns a typed result whose ``report`` is plain JSON-ready data (sizes in px,
chainage in m, times in s, angles in degrees, offsets in pipe heights H); the
command line only prints it and writes the debug image.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from pipeline.core.atomic import atomic_path
from pipeline.formats.certificate import load_certificate
from pipeline.camera.undistort import Undistorter
from pipeline.core.errors import PipegaugeError
from pipeline.vision.video.overlay_ocr import OverlayReader, parse_chainage
from pipeline.vision.video.reader import check_integrity, iter_frames, read_frame, read_image

__all__ = ["ProbeResult", "ProbeRequestError", "probe", "IMAGE_SUFFIXES"]

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff"}


class ProbeRequestError(PipegaugeError):
    """The probe asked for something the source cannot give (a chainage in a still, a frame past the end)."""


@dataclass
class ProbeResult:
    """``report``: what was read, JSON-ready; ``debug_image``: the (ideal) frame with the contour drawn, when asked."""

    report: dict
    debug_image: np.ndarray | None = None

    def save_debug_image(self, path: str | os.PathLike) -> Path:
        """Write the debug image atomically; an unwritable path or unknown extension raises OSError naming it."""
        path = Path(path)
        try:
            ok, data = cv2.imencode(path.suffix or ".png", self.debug_image)
        except cv2.error:
            ok = False
        if not ok:
            raise OSError(22, f"cannot encode an image as {path.suffix!r}; use .png or .jpg", str(path))
        with atomic_path(path) as tmp:
            tmp.write_bytes(data.tobytes())
        return path


def probe(source: str | os.PathLike, *, time_s: float | None = None, frame: int | None = None,
          chainage_m: float | None = None, certificate: str | os.PathLike | None = None, shape: str = "circular",
          draw: bool = False, reader: OverlayReader | None = None) -> ProbeResult:
    """Probe a video at a time [s], a frame index or the first frame at a chainage [m] (default: frame 0), or a still.

    certificate : check it fits the source and fit the pipe contour in the undistorted frame
    draw : keep the frame (undistorted with a certificate) with the rings and vanishing point drawn
    """
    path = Path(source)
    is_image = path.suffix.lower() in IMAGE_SUFFIXES
    reader = reader or OverlayReader()
    report: dict = {"source": str(path)}
    box, spread = None, {}       # spread: frames over the video kept by the track's pass (for the overlay mask)
    if is_image:
        if chainage_m is not None:
            raise ProbeRequestError(f"--chainage needs a video ({path} is an image)")
        image = read_image(path)
        index, first = 0, [image]
    else:
        if chainage_m is not None:
            ingest, index, mapping = _track(path, reader, chainage_m)
            info, box, spread = ingest.info, ingest.box, ingest.spread_frames
        else:
            info, mapping = check_integrity(path), {}
            index = int(round(time_s * info.fps)) if time_s is not None else (frame or 0)
        report["video"] = {"width": info.width, "height": info.height, "fps": info.fps,
                           "frames": info.frame_count, "duration_s": round(info.duration_s, 3), "codec": info.codec}
        report.update(mapping)
        if not 0 <= index < info.frame_count:
            raise ProbeRequestError(f"frame {index} is outside the video (0-{info.frame_count - 1})")
        if box is None:
            first = [f for _, f in iter_frames(path, every=max(1, info.frame_count // 4))][:3]
        image = read_frame(path, index)
    if box is None:
        box = reader.locate_chainage(first, str(path))
    read = reader.read(image, box, index)
    report["frame"] = index
    report["chainage"] = {"text": read.text, "m": read.value, "score": round(read.score, 4), "box_px": list(box)}
    text_lines = reader.lines(image)
    report["overlay_lines"] = [t for t, _, _ in text_lines if parse_chainage(t) is None]
    if not certificate:
        return ProbeResult(report, image if draw else None)
    cert = load_certificate(certificate)
    und = Undistorter(cert, image.shape[1], image.shape[0], str(path))
    report["certificate"] = cert.certificate_id
    grays = [cv2.cvtColor(und.frame(image), cv2.COLOR_BGR2GRAY)]
    mask = None
    if not is_image:
        from pipeline.vision.video.pipe_contour import overlay_mask, overlay_mask_of, read_ideal_grays

        around = [k for k in range(index - 3 * int(info.fps), index + 3 * int(info.fps) + 1, 6)
                  if 0 <= k < info.frame_count and k != index]
        more = read_ideal_grays(path, around, und)
        grays += [more[k] for k in around if k in more]
        mask = overlay_mask_of(spread.values(), und) if spread else overlay_mask(path, und)
    contour, drawing = _contour(grays, und, shape, mask)
    report["contour"] = contour
    still = None
    if is_image:
        report["still_ring"], still = _still_ring(grays[0], shape, [b for _, b, _ in text_lines] + [box])
    debug = _drawn(und.frame(image), drawing, still) if draw else None
    return ProbeResult(report, debug)


def _track(path: Path, reader: OverlayReader, chainage_m: float):
    """Fit the video's chainage track (one decoding pass) and find the first frame at ``chainage_m`` [m]:
    (the ingest, frame, {"track": ..., "at_chainage": ...} for the report)."""
    from pipeline.vision.video.ingest import ingest_chainage

    ingest = ingest_chainage(path, reader)
    track = ingest.track
    try:
        index, u_frames = track.frame_at(chainage_m)
    except ValueError:
        raise ProbeRequestError(f"{path}: the camera never reaches {chainage_m:g} m; its track runs from "
                                f"{track.values.min():.2f} m to {track.values.max():.2f} m") from None
    segment = next((kind for first, last, kind in track.segments if first <= index <= last), "moving")
    mapping = {
        "track": {"from_m": round(float(track.values.min()), 3), "to_m": round(float(track.values.max()), 3),
                  "reads_used": track.reads_used, "reads_rejected": len(track.rejected),
                  "segments": [{"first_frame": first, "last_frame": last, "camera": kind}
                               for first, last, kind in track.segments]},
        "at_chainage": {"m": chainage_m, "u_m": round(float(track.counter.u(chainage_m)), 4), "frame": index,
                        "u_frames": round(u_frames, 2) if np.isfinite(u_frames) else None,
                        "time_s": round(index / ingest.info.fps, 3), "camera": segment}}
    return ingest, index, mapping


def _contour(grays, und: Undistorter, shape: str, mask) -> tuple[dict, dict]:
    """The pipe contour of the first frame (pose from all), summarised; and the polygons to draw [px]."""
    from pipeline.vision.contour import detect_contour

    pc = detect_contour(grays, und.K, shape, mask=mask)
    out = {"confident": pc.confident, "problems": pc.problems, "rings": len(pc.rings),
           "ring_rms_px": None if not pc.rings else round(pc.rms_px, 3)}
    drawing: dict = {}
    if pc.rings:
        v = pc.view
        out.update(vanishing_point_px=[round(float(c), 2) for c in v.vanishing_point],
                   camera_offset_H=[round(v.ox, 4), round(v.oy, 4)],
                   yaw_pitch_roll_deg=[round(float(np.degrees(a)), 3) for a in (v.yaw, v.pitch, v.roll)])
        own = [r for r in pc.rings if r.frame == 0]
        out["rings_in_frame"] = [{"depth_H": round(r.depth, 4), "p_H_px": round(r.p_H, 2),
                                  "arc_coverage_deg": r.coverage_deg, "rms_px": round(r.rms_px, 3)} for r in own]
        mid = np.median([r.depth for r in own or pc.rings])
        plane = pc.at_point(v.project([[0.0, 0.5, mid]])[0])
        out["plane_at_median_ring"] = {"depth_H": round(plane.depth, 4), "p_H_px": round(plane.p_H, 2),
                                       "u_p_H_px": round(plane.u_p_H, 3), "confident": plane.confident}
        drawing = {"polygons": [v.ring(r.depth) for r in own] or [plane.polygon], "vp": v.vanishing_point}
    return out, drawing


def _still_ring(gray, shape: str, text_boxes) -> tuple[dict, np.ndarray | None]:
    """The ring of a single still (``pipeline.vision.contour.still``), the overlay's text boxes masked out; and its polygon."""
    from pipeline.vision.contour.still import ring_in_still

    mask = np.full(gray.shape, 255, np.uint8)
    for x0, y0, x1, y1 in text_boxes:
        mask[max(0, y0 - 6):y1 + 7, max(0, x0 - 6):x1 + 7] = 0
    ring = ring_in_still(gray, shape, mask=mask)
    if ring is None:
        return {"found": False, "problems": ["no closed ring of the header's profile stands out in this still"]}, None
    return ({"found": True, "confident": ring.confident, "problems": list(ring.problems),
             "centre_px": [round(c, 2) for c in ring.centre], "p_H_px": round(ring.p_H, 2),
             "u_p_H_px": round(ring.u_p_H, 2), "points": ring.n_points, "arc_coverage_deg": ring.coverage_deg,
             "rms_px": round(ring.rms_px, 3)}, ring.polygon)


def _drawn(image: np.ndarray, drawing: dict, still: np.ndarray | None) -> np.ndarray:
    """The ideal frame with the rings found (green), the still's ring (yellow) and the vanishing point (red)."""
    for poly in drawing.get("polygons", []):
        cv2.polylines(image, [np.round(np.asarray(poly)).astype(np.int32)], True, (0, 255, 0), 1, cv2.LINE_AA)
    if still is not None:
        cv2.polylines(image, [np.round(np.asarray(still)).astype(np.int32)], True, (0, 255, 255), 2, cv2.LINE_AA)
    vp = drawing.get("vp")
    if vp is not None:
        cv2.drawMarker(image, (int(round(vp[0])), int(round(vp[1]))), (0, 0, 255), cv2.MARKER_CROSS, 15, 2)
    return image
