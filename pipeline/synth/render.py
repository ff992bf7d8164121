"""Ray-cast rendering of a pipe seen by a calibrated camera.

Every pixel's ray comes from the certificate (``rig.pixel_rays``), so the
image is distorted exactly as the certificate says. The camera travels along
the pipe at a fixed offset and orientation, so each ray's intersection with
the pipe wall *in the cross-section plane* does not change from frame to
frame; only where along the pipe it lands does. The renderer therefore
solves the 2-D geometry once (exact ray-polygon exit distances) and per frame
only shifts the hits along Z, which is what makes it fast.

Shading: a lamp at the camera, Lambert reflection, inverse-square fall-off
(the far pipe fades to a dark centre), a logarithmic camera response, sensor
noise and a slight optical blur. Thin features (joints, cracks) are anti-aliased from
their width and the wall footprint of each pixel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from pipeline.camera import Certificate
from pipeline.maths.profiles import clock_to_theta, exit_table, perimeter, profile_polygon, segment_height_for_area_fraction, wall_point
from pipeline.camera.pose import camera_rotation, pixel_rays
from pipeline.synth.appearance import SENSOR_NOISE, Appearance
from pipeline.synth.scene import Connection, Crack, Deformation, Deposit, DisplacedJoint, Marker, Scene
from pipeline.synth.texture import MATERIALS, TEXEL_MM, wall_texture

__all__ = ["Renderer"]

S_MAX = 60_000.0        # [mm] rays along the axis end here (black)
_GAIN = 0.6
_AMBIENT = 0.015
_WHITE = 6.0
_LUT_SIZE, _LUT_MAX = 4096, 16.0
LIP_MM = 20.0                         # width of the socket face seen before each joint gap
_TEX_PERIOD_MM = 2048 * TEXEL_MM      # a power of two of texels: the z index wraps with a bit mask

# Region palette (BGR); index 0 is the wall, whose tint comes from the material.
_WALL, _WATER, _DEPOSIT, _LATERAL, _HOLE, _MARKER = range(6)


@dataclass
class _Hits:
    """Per-pixel wall hits of one pipe segment (flat float32 arrays)."""

    s: np.ndarray       # distance along the unit ray [mm]
    theta: np.ndarray   # angle of the hit around the profile centre [rad]
    cos: np.ndarray     # cosine of incidence
    fp: np.ndarray      # wall footprint of the pixel [mm]
    light: np.ndarray   # lamp irradiance factor (before albedo)
    iu: np.ndarray      # texture column

    FIELDS = ("s", "theta", "cos", "fp", "light", "iu")

    def put(self, where, other: "_Hits", other_where=slice(None)) -> None:
        """Take the hits of ``other`` at ``other_where`` into the pixels ``where``."""
        for name in self.FIELDS:
            getattr(self, name)[where] = getattr(other, name)[other_where]


class Renderer:
    """Renders frames of ``scene`` for a camera at a fixed offset and orientation.

    offset_mm : (X, Y) of the camera centre in the cross-section [mm]
    yaw, pitch, roll : camera orientation [rad] (see ``rig.camera_rotation``)
    noise : standard deviation of the sensor noise [grey levels of 255]
    appearance : the optics' blur, the response, vignetting and the joints' look (``synth.appearance``)
    """

    def __init__(self, scene: Scene, cert: Certificate, *, offset_mm=(0.0, 0.0), yaw=0.0, pitch=0.0, roll=0.0,
                 seed: int = 0, noise: float = SENSOR_NOISE, appearance: Appearance = Appearance()):
        self.scene, self.cert = scene, cert
        self.look = look = appearance
        self.W, self.H = cert.image_width_px, cert.image_height_px
        self.f = float(cert.focal_px[0])
        self.ox, self.oy = (float(v) for v in offset_mm)
        self.rng = np.random.default_rng(seed)
        rays = pixel_rays(cert).reshape(-1, 3) @ camera_rotation(yaw, pitch, roll).T.astype(np.float32)
        self.dx, self.dy, self.dz = (np.ascontiguousarray(rays[:, i]) for i in range(3))

        pipe = scene.pipe
        self.pipe = pipe
        self.material = MATERIALS[pipe.material]
        self.poly = profile_polygon(pipe.shape, pipe.height_mm)
        self.perimeter = perimeter(pipe.shape, pipe.height_mm)
        self.r_eq = self.perimeter / (2 * math.pi)
        self.s_ref = 1.0 * pipe.height_mm
        self.tex = wall_texture(self.material, self.perimeter, _TEX_PERIOD_MM, self.rng)
        self.tex_mean = float(self.tex.mean())

        self.seg1 = self._wall_hits((0.0, 0.0))
        self._deformed: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        joints = scene.of_type(DisplacedJoint)
        if len(joints) > 1:
            raise ValueError("the renderer supports one displaced joint per scene")
        self.djoint = joints[0] if joints else None
        self.seg2 = None
        if self.djoint:
            th = clock_to_theta(self.djoint.clock)
            self.step_vec = (self.djoint.step_mm * math.cos(th), self.djoint.step_mm * math.sin(th))
            self.seg2 = self._wall_hits(self.step_vec)

        h_w = scene.water_percent / 100.0 * pipe.height_mm
        self.water_y = -pipe.height_mm / 2 + h_w
        self.s_water = self._plane_hits(self.water_y) if h_w > 0 else None
        self.deposits = [(d, -pipe.height_mm / 2 + segment_height_for_area_fraction(pipe.shape, pipe.height_mm, d.area_percent / 100))
                         for d in scene.of_type(Deposit)]
        self.deposit_s = [self._plane_hits(y) for _, y in self.deposits]
        self.deposit_rays = [np.nonzero(np.isfinite(s_d))[0] for s_d in self.deposit_s]

        self.laterals = []
        for c in scene.of_type(Connection):
            if c.intrusion_mm > 0:
                th = clock_to_theta(c.clock)
                self.laterals.append((c, wall_point(pipe.shape, pipe.height_mm, th), th))
        self.palette = np.array([self.material.tint_bgr, (0.40, 0.50, 0.50), (0.45, 0.62, 0.75),
                                 (0.70, 0.74, 0.78), (0.25, 0.25, 0.25), (1.0, 1.0, 1.0)], dtype=np.float32)
        x = (np.arange(_LUT_SIZE, dtype=np.float64) + 0.5) * (_LUT_MAX / _LUT_SIZE)
        # A logarithmic response, like a CCTV camera's auto-exposure and knee: the far wall
        # stays visible for metres before the centre turns black.
        tone = np.clip(np.log1p(look.tone_k * x) / np.log1p(look.tone_k * _WHITE) + _AMBIENT, 0, 1)
        self.tone_lut = np.rint(255 * tone**look.gamma).astype(np.uint8)
        levels = np.arange(256, dtype=np.float64)
        # tint_luts[region, channel, brightness] -> display value
        self.tint_luts = np.rint(levels[None, None, :] * (self.palette[:, :, None] ** look.gamma)).astype(np.uint8)
        bank = np.rint(noise * self.rng.standard_normal((self.H + 16, self.W + 16, 3)))
        self.noise_up = np.clip(bank, 0, 255).astype(np.uint8)
        self.noise_down = np.clip(-bank, 0, 255).astype(np.uint8)
        self.vignette = None
        if look.vignette > 0:
            # the lens's fall-off: the corners lose ``vignette`` of their light, with the square of the radius
            v, u = np.mgrid[0:self.H, 0:self.W].astype(np.float32)
            r2 = ((u - 0.5 * (self.W - 1)) ** 2 + (v - 0.5 * (self.H - 1)) ** 2) / (0.25 * (self.W ** 2 + self.H ** 2))
            self.vignette = (1.0 - look.vignette * r2).ravel()

    # -- geometry that does not depend on the camera's Z ----------------------
    def _wall_hits(self, centre: tuple[float, float]) -> _Hits:
        """Hits on the wall of a segment whose profile is shifted by ``centre`` [mm]."""
        phi_t, t_t, n_t = exit_table(self.poly, (self.ox - centre[0], self.oy - centre[1]))
        dxy = np.hypot(self.dx, self.dy)
        phi = np.arctan2(self.dy, self.dx)
        k = np.rint((phi + np.pi) / (2 * np.pi) * len(phi_t)).astype(np.int64) % len(phi_t)
        t = np.interp(phi, phi_t, t_t, period=2 * np.pi)
        with np.errstate(divide="ignore"):
            s = np.minimum(t / np.maximum(dxy, 1e-9), S_MAX)
        X = self.ox + s * self.dx - centre[0]
        Y = self.oy + s * self.dy - centre[1]
        cos = np.abs(n_t[k, 0] * self.dx + n_t[k, 1] * self.dy)
        return self._hits(s, np.arctan2(Y, X), cos)

    def _hits(self, s, theta, cos) -> _Hits:
        s = np.asarray(s, np.float32)
        cos = np.clip(np.asarray(cos, np.float32), 0.0, 1.0)
        fp = s / (self.f * np.maximum(cos, 0.05))
        light = _GAIN * cos * (self.s_ref / np.maximum(s, 1.0)) ** 2
        iu = (np.rint(theta * self.r_eq / TEXEL_MM).astype(np.int64) % self.tex.shape[1])
        return _Hits(s, np.asarray(theta, np.float32), cos, fp.astype(np.float32), light.astype(np.float32), iu)

    def _plane_hits(self, y_plane: float) -> np.ndarray:
        """Distance to the horizontal plane Y = y_plane for rays going down (inf otherwise)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.where(self.dy < -1e-6, (y_plane - self.oy) / self.dy, np.inf)
        return s.astype(np.float32)

    # -- one frame ---------------------------------------------------------------
    def render(self, z_cam: float, time_s: float = 0.0, frame: int = 0) -> np.ndarray:
        """The frame (H, W, 3) uint8 BGR with the camera centre at Z = z_cam [mm] (no overlay).

        ``frame`` picks the sensor-noise pattern, so a frame renders the same
        whichever process renders it and in whatever order.
        """
        hits, end_face = self._segments(z_cam)
        z = z_cam + hits.s * self.dz
        if self.scene.of_type(Deformation):
            # _deform may change a copy's hits in place: the wall positions must follow it either way
            hits = self._deform(hits, z, z_cam)
            z = z_cam + hits.s * self.dz

        albedo = self._albedo(hits, z)
        groove, lip = self._joint_coverage(z, hits.fp)
        groove[end_face] = 0.0          # a far pipe's own end face beyond the gap ("apart"): its concrete, not the gap
        albedo *= 1.0 - self.look.groove * groove
        region = np.zeros(z.shape, np.uint8)
        self._wall_marks(albedo, region, hits, z)

        lum = albedo * hits.light
        # the far pipe's end face reflects ``Appearance.face_albedo`` times the wall's light, inside as at its edges
        # (``_face_edges``); until 2026-12-07's eighth session only its edge pixels were, so a face drawn brighter
        # read wider at both edges and darker narrower (its step 0.8 mm long in DN300 at 1.75 times one material's:
        # ``benchmarks/joint_tilt.py --placement --ends apart --face 1.4`` with the renderer before)
        lum[end_face] *= self.look.face_albedo
        # The socket's end face looks at the camera: lit almost head-on, unlike the grazing wall.
        faces = np.nonzero(lip)[0]
        lum[faces] *= 1.0 + lip[faces] * (np.minimum(self.look.face_gain / np.maximum(hits.cos[faces], 0.05), 8.0) - 1.0)
        if self.djoint is not None and self.djoint.ends == "apart" and not self.scene.of_type(Deformation):
            # also where no pixel's centre sees the face: a face thinner than a pixel still lights its pixels
            self._face_edges(lum, z_cam)
        s_cur = hits.s.copy()
        self._deposits(lum, region, s_cur, z_cam)
        self._connections(lum, region, s_cur, z_cam)
        if self.s_water is not None:
            water = self.s_water < s_cur
            if water.any():
                sw = self.s_water[water]
                zw = z_cam + sw * self.dz[water]
                xw = self.ox + sw * self.dx[water]
                ripple = 1.0 + 0.15 * np.sin(0.045 * zw + 0.07 * xw + 3.0 * time_s)
                lum[water] = 0.12 * ripple * _GAIN * np.abs(self.dy[water]) * (self.s_ref / sw) ** 2
                region[water] = _WATER
                s_cur[water] = sw

        if self.vignette is not None:
            lum *= self.vignette
        # Tone curve and gamma give an 8-bit brightness; each region's tint then scales it per
        # channel ((lum * tint)^g = lum^g * tint^g), through 256-entry tables.
        idx = np.minimum((lum * (_LUT_SIZE / _LUT_MAX)).astype(np.int32), _LUT_SIZE - 1)
        bright = self.tone_lut[idx].reshape(self.H, self.W)
        out = cv2.merge([cv2.LUT(bright, self.tint_luts[0][c]) for c in range(3)])
        present = np.nonzero(np.bincount(region, minlength=len(self.palette)))[0]
        region = region.reshape(self.H, self.W)
        for r in present[present > 0]:
            tinted = cv2.merge([cv2.LUT(bright, self.tint_luts[r][c]) for c in range(3)])
            cv2.copyTo(tinted, (region == r).view(np.uint8), out)
        oy, ox = (frame * 7) % 16, (frame * 11 + frame // 16) % 16
        out = cv2.add(out, self.noise_up[oy:oy + self.H, ox:ox + self.W])
        out = cv2.subtract(out, self.noise_down[oy:oy + self.H, ox:ox + self.W])
        k = 2 * round(2.5 * self.look.blur_px) + 1       # 5 x 5 for the default 0.9 px
        return cv2.GaussianBlur(out, (k, k), self.look.blur_px)

    def _segments(self, z_cam: float) -> tuple[_Hits, np.ndarray]:
        """Wall hits for this frame: the first segment, the displaced one beyond its joint, and the step face; and
        the pixels on the far pipe's end face where the ends stand apart (``DisplacedJoint.ends``)."""
        seg1, seg2, dj = self.seg1, self.seg2, self.djoint
        none = np.zeros(0, np.int64)
        if dj is None:
            return seg1, none
        zj = dj.joint * self.pipe.unit_length_mm
        # "painted": both pipes end at the joint's plane; "apart": the near one gap / 2 before it, the far one
        # gap / 2 beyond it, with nothing between them (a ray reaching the near pipe's wall in between meets the
        # dark of the gap, which ``_joint_coverage`` paints there)
        half = 0.5 * dj.gap_mm if dj.ends == "apart" else 0.0
        z_near, z_far = zj - half, zj + half
        if z_far <= z_cam:
            return seg2, none
        z1 = z_cam + seg1.s * self.dz
        beyond = z1 > z_near
        if not beyond.any():
            return seg1, none
        out = _copy(seg1)
        z2 = z_cam + seg2.s * self.dz
        use2 = beyond & (z2 > z_far)
        out.put(use2, seg2, use2)
        # a ray that passes the near pipe's end inside its wall and would meet the far pipe's wall before that pipe
        # begins meets the far pipe's end face
        face = np.nonzero(beyond & ~use2 & (z1 > z_far))[0]
        if face.size:
            sf = (z_far - z_cam) / self.dz[face]
            X, Y = self.ox + sf * self.dx[face], self.oy + sf * self.dy[face]
            out.put(face, self._hits(sf, np.arctan2(Y, X), self.dz[face]))
        return out, (face if dj.ends == "apart" else none)

    def _face_edges(self, lum: np.ndarray, z_cam: float) -> None:
        """Anti-alias the far pipe's end face (``DisplacedJoint.ends`` "apart") in ``lum``, in place.

        Each pixel's centre ray says whether it sees the face, the gap or the far pipe's wall; a pixel the face's
        edge crosses sees part of each. The gap's own anti-aliasing (``_joint_coverage``) places a pixel by where
        its ray meets the near pipe's radius and takes the wall beyond the gap's far edge for the rest of it. Beside
        the face that painted the gap's last half pixel as grazing wall where the bright face is, and the far
        wall's first as half gap (the face's edges read half a footprint onto the face from both sides, the step
        short: DN800 stepped 30 mm at 1 m, -1.4 mm; ``benchmarks/joint_tilt.py --placement --ends apart`` before
        2026-12-07's fifth session); where the far pipe stands out of the wall, it left the gap's side of its far
        edge (where the ray meets the far pipe's wall at its plane) wholly dark. Here each pixel near the face takes
        the face's share of its footprint across each edge (the distance of its centre from the edge in footprints,
        as ``_joint_coverage``), the rest from the surface beside that edge: the gap, dark throughout, or the far
        wall, without the gap's darkening; a face thinner than a footprint its width's share (until 2026-12-07's
        sixth session, a quarter of a pixel at least, all around the gap once any pixel's centre saw a face:
        ``tests/test_joints.py``). Where the far pipe stands out, each pixel at the gap's far edge takes the
        wall's share of its footprint there. Not under a deformation (its hits are not the segments' own)."""
        dj, seg1, seg2 = self.djoint, self.seg1, self.seg2
        z_joint = dj.joint * self.pipe.unit_length_mm
        z_near, z_far = z_joint - 0.5 * dj.gap_mm, z_joint + 0.5 * dj.gap_mm
        if z_far <= z_cam:
            return                              # the camera past the far end: no face ahead
        z1, z2 = z_cam + seg1.s * self.dz, z_cam + seg2.s * self.dz
        with np.errstate(invalid="ignore", divide="ignore"):
            d1 = (z1 - z_far) / seg1.fp          # > 0: past the near pipe's radius only beyond the far end's plane
            d2 = (z_far - z2) / seg2.fp          # > 0: at the far pipe's radius before that pipe begins
        ahead = self.dz > 0
        # where the far pipe stands into the flow (its wall met before the near one's), the face lies between the
        # two radii at the far end's plane
        band = np.nonzero(ahead & (z2 < z1) & (d1 > -0.5) & (d2 > -0.5) & (np.minimum(d1, d2) < 0.5))[0]
        if band.size:
            # the footprint's share on the gap's side of the face's near edge, and on the far wall's side of its far
            # edge; the face takes the rest (a face thinner than the footprint, its width's share of it)
            on_gap = np.clip(0.5 - d1[band], 0.0, 1.0)
            on_wall = np.clip(0.5 - d2[band], 0.0, 1.0)
            cover = np.clip(1.0 - on_gap - on_wall, 0.0, 1.0)
            sf = (z_far - z_cam) / self.dz[band]
            X, Y = self.ox + sf * self.dx[band], self.oy + sf * self.dy[band]
            face = self._hits(sf, np.arctan2(Y, X), self.dz[band])
            lum_face = self._albedo(face, np.full(band.size, z_far, np.float32)) * face.light * self.look.face_albedo
            gap, wall = self._gap_and_wall(band, z1, z2)
            rest = np.maximum(on_gap + on_wall, 1e-9)
            lum[band] = cover * lum_face + (1.0 - cover) * (on_gap * gap + on_wall * wall) / rest
        # where it stands out of the wall (or flush), the gap's far edge is where a ray meets the far pipe's wall at
        # its plane: the gap's anti-aliasing, which places the pixel by where it meets the near pipe's radius,
        # left the gap's side of that edge wholly dark (the edge read deeper by a tenth of a pixel and more). Not
        # where the footprint reaches the near pipe's end too (a gap under a pixel): that anti-aliasing holds there
        with np.errstate(invalid="ignore", divide="ignore"):
            clear = (z1 - z_near) / seg1.fp > 0.5
        edge = np.nonzero(ahead & (z2 >= z1) & (np.abs(d2) < 0.5) & clear)[0]
        if edge.size:
            on_wall = np.clip(0.5 - d2[edge], 0.0, 1.0)
            gap, wall = self._gap_and_wall(edge, z1, z2)
            lum[edge] = on_wall * wall + (1.0 - on_wall) * gap

    def _gap_and_wall(self, at: np.ndarray, z1: np.ndarray, z2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The light of the gap (the near pipe's hits, darkened by the gap) and of the far pipe's wall at pixels
        ``at``, whose rays meet the two pipes' radii at z1 and z2 [mm]."""
        seg1, seg2 = self.seg1, self.seg2
        gap = (self._albedo(_take(seg1, at), z1[at]) * seg1.light[at]) * (1.0 - self.look.groove)
        wall = self._albedo(_take(seg2, at), z2[at]) * seg2.light[at]
        return gap, wall

    def _albedo(self, hits: _Hits, z: np.ndarray) -> np.ndarray:
        """The wall's albedo at hits whose Z is z [mm]: its texture, averaged out where a pixel covers many texels."""
        iz = (z * (1.0 / TEXEL_MM)).astype(np.int32) & (self.tex.shape[0] - 1)
        amp = np.minimum(2.0 * TEXEL_MM / hits.fp, 1.0)
        return self.tex_mean + (self.tex[iz, hits.iu] - self.tex_mean) * amp

    def _deformed_hits(self, d: Deformation) -> tuple[np.ndarray, np.ndarray]:
        """(s, cos) of every ray against the fully deformed section: an ellipse, invert in place."""
        R, e = self.pipe.height_mm / 2, d.percent / 100.0
        a, b = R * (1 + e), R * (1 - e)
        oy = self.oy + R * e                       # camera relative to the ellipse centre (-R + b)
        dx, dy = self.dx.astype(np.float64), self.dy.astype(np.float64)
        A = dx * dx / a**2 + dy * dy / b**2
        B = 2 * (self.ox * dx / a**2 + oy * dy / b**2)
        C = self.ox**2 / a**2 + oy**2 / b**2 - 1
        with np.errstate(divide="ignore", invalid="ignore"):
            s = np.minimum((-B + np.sqrt(np.maximum(B * B - 4 * A * C, 0))) / (2 * A), S_MAX)
        nx, ny = (self.ox + s * dx) / a**2, (oy + s * dy) / b**2
        cos = np.abs(nx * dx + ny * dy) / np.hypot(nx, ny)
        return s.astype(np.float32), cos.astype(np.float32)

    def _deform(self, hits: _Hits, z: np.ndarray, z_cam: float) -> _Hits:
        """Rays landing in a deformation zone meet the deformed wall instead.

        Along each ray the wall moves from the circle (outside the zone) to the
        fully deformed ellipse (inside it) as the zone's smooth ramp w(Z) goes
        from 0 to 1: s = s_circle + w(Z(s)) (s_ellipse - s_circle), solved by
        two fixed-point steps. Inside the zone the section is exactly the ellipse.
        """
        for d in self.scene.of_type(Deformation):
            if self.pipe.shape != "circular":
                raise ValueError(f"deformation {d.id}: supported on circular pipes only")
            if d.id not in self._deformed:
                self._deformed[d.id] = self._deformed_hits(d)
            s_def, cos_def = self._deformed[d.id]
            margin = d.ramp_mm + 2 * d.percent / 100 * self.pipe.height_mm + 50
            band = np.nonzero((z > d.z_from_mm - margin) & (z < d.z_to_mm + margin))[0]
            if band.size == 0:
                continue
            s0, ds, dz = hits.s[band], s_def[band] - hits.s[band], self.dz[band]
            w = _ramp(z_cam + s0 * dz, d.z_from_mm, d.z_to_mm, d.ramp_mm)
            w = _ramp(z_cam + (s0 + w * ds) * dz, d.z_from_mm, d.z_to_mm, d.ramp_mm)
            s = s0 + w * ds
            cos = hits.cos[band] + w * (cos_def[band] - hits.cos[band])
            if hits is self.seg1 or hits is self.seg2:
                hits = _copy(hits)
            # The wall angle of the hit moves by well under a degree: texture and marks keep it.
            hits.s[band] = s
            hits.cos[band] = cos
            hits.fp[band] = s / (self.f * np.maximum(cos, 0.05))
            hits.light[band] = _GAIN * cos * (self.s_ref / np.maximum(s, 1.0)) ** 2
        return hits

    def _joint_coverage(self, z: np.ndarray, fp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Coverage of each pixel by a joint's gap (dark) and by the socket face just before it (bright)."""
        L = self.pipe.unit_length_mm
        k = np.rint(z * (1.0 / L))
        dz = z - k * L
        widest = max(self.pipe.gap_mm, self.djoint.gap_mm if self.djoint else 0.0) / 2 + LIP_MM
        near = np.nonzero((np.abs(dz) < widest + fp) & (k >= 1))[0]
        groove = np.zeros(z.shape, np.float32)
        lip = np.zeros(z.shape, np.float32)
        dzn, fpn = dz[near], fp[near]
        half = np.full(near.shape, self.pipe.gap_mm / 2, np.float32)
        if self.djoint is not None:
            half[k[near] == self.djoint.joint] = self.djoint.gap_mm / 2
        groove[near] = np.clip((half - np.abs(dzn)) / fpn + 0.5, 0.0, 1.0)
        lip[near] = np.clip((LIP_MM / 2 - np.abs(dzn + half + LIP_MM / 2)) / fpn + 0.5, 0.0, 1.0)
        return groove, lip

    def _wall_marks(self, albedo, region, hits: _Hits, z) -> None:
        """Cracks, connection openings and markers painted on the wall, anti-aliased."""
        r_eq = self.r_eq
        for c in self.scene.of_type(Crack):
            if c.orientation == "circumferential":
                band = np.nonzero(np.abs(z - c.z_mm) < c.width_mm + 40)[0]
                if band.size == 0:
                    continue
                th = hits.theta[band]
                t0, t1 = clock_to_theta(c.clock_from), clock_to_theta(c.clock_to)
                inside = ((t0 - th) % (2 * np.pi)) <= ((t0 - t1) % (2 * np.pi))
                centre = c.centre_z(th)
                dist = np.abs(z[band] - centre)
            else:
                band = np.nonzero((z > c.z_mm - 20) & (z < c.z_mm + c.length_mm + 20))[0]
                if band.size == 0:
                    continue
                zb = z[band]
                inside = (zb >= c.z_mm) & (zb <= c.z_mm + c.length_mm)
                centre = c.centre_u(zb, r_eq)
                dist = np.abs(_wrap(hits.theta[band] * r_eq - centre, 2 * np.pi * r_eq))
            cov = np.clip((c.width_mm / 2 - dist) / hits.fp[band] + 0.5, 0.0, 1.0) * inside
            albedo[band] *= 1.0 - 0.9 * cov
        for m in self.scene.of_type(Marker):
            band = np.nonzero(np.abs(z - m.z_mm) < m.radius_mm + 30)[0]
            if band.size == 0:
                continue
            du = _wrap(hits.theta[band] * r_eq - clock_to_theta(m.clock) * r_eq, 2 * np.pi * r_eq)
            dist = np.hypot(du, z[band] - m.z_mm)
            cov = np.clip((m.radius_mm - dist) / hits.fp[band] + 0.5, 0.0, 1.0)
            # Retro-reflective: as bright at any distance, a clear target even in the dark far field.
            albedo[band] = albedo[band] * (1 - cov) + cov * (4.0 / np.maximum(hits.light[band], 1e-6))
            region[band[cov > 0.5]] = _MARKER
        for c in self.scene.of_type(Connection):
            band = np.nonzero(np.abs(z - c.z_mm) < c.diameter_mm / 2 + c.wall_mm + 30)[0]
            if band.size == 0 or c.intrusion_mm > 0:
                continue
            du = _wrap(hits.theta[band] * r_eq - clock_to_theta(c.clock) * r_eq, 2 * np.pi * r_eq)
            dist = np.hypot(du, z[band] - c.z_mm)
            hole = np.clip((c.diameter_mm / 2 - dist) / hits.fp[band] + 0.5, 0.0, 1.0)
            albedo[band] *= 1.0 - 0.92 * hole
            region[band[hole > 0.5]] = _HOLE

    def _deposits(self, lum, region, s_cur, z_cam: float) -> None:
        for (d, y_top), s_d, below in zip(self.deposits, self.deposit_s, self.deposit_rays):
            if d.z_to_mm < z_cam:
                continue
            # Rays meeting the deposit's top plane before the wall; the front face is only
            # reachable by the same rays (it lies below the top plane).
            cand = below[s_d[below] < s_cur[below]]
            if cand.size == 0:
                continue
            dz = self.dz[cand]
            sd = s_d[cand]
            zd = z_cam + sd * dz
            top = (zd >= d.z_from_mm) & (zd <= d.z_to_mm)
            with np.errstate(divide="ignore", invalid="ignore"):
                sf = np.where(dz > 1e-6, (d.z_from_mm - z_cam) / dz, np.inf)
            face = (sf > 0) & (sf < s_cur[cand]) & (self.oy + sf * self.dy[cand] < y_top) & ~top
            for mask, s_hit, cos in ((top, sd, np.abs(self.dy[cand])), (face, sf, dz)):
                if not mask.any():
                    continue
                at = cand[mask]
                sh = s_hit[mask].astype(np.float32)
                zz = z_cam + sh * self.dz[at]
                xx = self.ox + sh * self.dx[at]
                grain = self.tex[(zz / TEXEL_MM).astype(np.int64) % self.tex.shape[0],
                                 ((xx + 5000.0) / TEXEL_MM).astype(np.int64) % self.tex.shape[1]]
                lum[at] = (0.35 + 0.6 * grain) * _GAIN * cos[mask] * (self.s_ref / sh) ** 2
                region[at] = _DEPOSIT
                s_cur[at] = sh

    def _connections(self, lum, region, s_cur, z_cam: float) -> None:
        """Intruding laterals: the protruding tube (lit) and its open end (dark)."""
        for c, (wx, wy), th in self.laterals:
            if not (0 < c.z_mm - z_cam < 8000):
                continue
            axis = np.array([-math.cos(th), -math.sin(th), 0.0])          # into the pipe
            w = np.array([self.ox - wx, self.oy - wy, z_cam - c.z_mm])
            # Only rays inside the cone around the tube's bounding sphere can meet it.
            centre = -w + 0.5 * c.intrusion_mm * axis
            dist = float(np.linalg.norm(centre))
            radius = math.hypot(c.diameter_mm / 2 + c.wall_mm, c.intrusion_mm / 2) + 5.0
            if dist <= radius:
                continue
            cone = (self.dx * centre[0] + self.dy * centre[1] + self.dz * centre[2]) > dist * math.sqrt(1 - (radius / dist) ** 2)
            sub = np.nonzero(cone)[0]
            if sub.size == 0:
                continue
            dx, dy, dz = self.dx[sub], self.dy[sub], self.dz[sub]
            wd = dx * axis[0] + dy * axis[1]
            ww = float(w @ axis)
            dpx, dpy, dpz = dx - wd * axis[0], dy - wd * axis[1], dz
            wp = w - ww * axis
            r_in, r_out = c.diameter_mm / 2, c.diameter_mm / 2 + c.wall_mm
            A = dpx**2 + dpy**2 + dpz**2
            B = 2 * (wp[0] * dpx + wp[1] * dpy + wp[2] * dpz)
            C = float(wp @ wp) - r_out**2
            disc = B * B - 4 * A * C
            with np.errstate(invalid="ignore", divide="ignore"):
                s_side = (-B - np.sqrt(disc)) / (2 * A)
                t_side = ww + s_side * wd
                side = (disc > 0) & (s_side > 0) & (t_side >= 0) & (t_side <= c.intrusion_mm) & (s_side < s_cur[sub])
                s_cap = (c.intrusion_mm - ww) / wd
                px = wp[0] + s_cap * dpx
                py = wp[1] + s_cap * dpy
                pz = wp[2] + s_cap * dpz
                rho = np.sqrt(px**2 + py**2 + pz**2)
            cap = (s_cap > 0) & (rho < r_out) & (s_cap < s_cur[sub]) & (~side | (s_cap < s_side))
            if side.any():
                sh = s_side[side]
                nx = (wp[0] + sh * dpx[side]) / r_out
                ny = (wp[1] + sh * dpy[side]) / r_out
                nz = (wp[2] + sh * dpz[side]) / r_out
                cos = np.abs(nx * dx[side] + ny * dy[side] + nz * dz[side])
                at = sub[side]
                lum[at] = 0.7 * _GAIN * cos * (self.s_ref / sh) ** 2
                region[at] = _LATERAL
                s_cur[at] = sh
            if cap.any():
                sh = s_cap[cap]
                rim = rho[cap] >= r_in
                at = sub[cap]
                lum[at] = np.where(rim, 0.7 * _GAIN * np.abs(wd[cap]) * (self.s_ref / sh) ** 2, 0.02)
                region[at] = np.where(rim, _LATERAL, _HOLE)
                s_cur[at] = sh


def _copy(h: _Hits) -> _Hits:
    return _Hits(*(getattr(h, name).copy() for name in _Hits.FIELDS))


def _take(h: _Hits, where: np.ndarray) -> _Hits:
    return _Hits(*(getattr(h, name)[where] for name in _Hits.FIELDS))


def _ramp(z, z0: float, z1: float, ramp: float):
    """0 outside [z0 - ramp, z1 + ramp], 1 inside [z0, z1], smooth (smoothstep) transitions between."""
    t = np.clip(np.minimum(z - (z0 - ramp), (z1 + ramp) - z) * (1.0 / ramp), 0, 1)
    return t * t * (3 - 2 * t)


def _wrap(d, period: float):
    return (d + period / 2) % period - period / 2
