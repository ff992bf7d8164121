"""What a video codec does to an edge found in its frames: the u [px] its blocks give an edge coordinate.

A night's video is always coded; the frames' edges are found after the codec's quantisation, which blurs a dark
feature's rim and moves it (an opening's, a joint's far end standing into the pipe) by a fraction of a pixel, the
same way in every frame of one approach. The figures are by codec family, read from the video's FourCC
(``pipeline.ingest``), and were set on generated video paired with its rendered frames (docs/measurement.md).
"""

from __future__ import annotations

import math

__all__ = ["MPEG4_PART2", "H264", "MPEG2", "CODEC_EDGE_U_PX", "CODEC_RIM_U_PX", "CODEC_GAP_U_PX", "CODEC_STEP_U_PX",
           "CODEC_U_PX", "Bands", "CODEC_FAMILIES", "codec_edge_u"]

MPEG4_PART2 = frozenset({"mp4v", "fmp4", "xvid", "divx", "dx50"})
# The u [px] MPEG-4 Part 2's 8x8 blocks give an edge coordinate of an intruding lateral's base and tip (and of an
# opening's rim until 2026-12-06, ``CODEC_RIM_U_PX`` below): through OpenCV's mp4v (the samples' codec) 17 of 105
# BCA and 10 of 68 BAG missed their U95 with the clean frames' u alone (seed 40; median z -0.02 and +0.08: no bias,
# heavy tails). 0.5 px was set there, on a benchmark whose pose rested on too few rings (docs/measurement.md); with
# the night's 4 m window of ring frames and the frames' value check, 0.5 px made the intervals twice the errors
# (robust SD of z 0.48 BCA, 0.53 BAG, seed 43) and 0.2 px brings both to about 95 % with SD 0.8 there (0 px:
# 90-92 %); checked on seed 44.
# H.264 (x264 at CRF 23 in the benchmark) shortens an opening more: paired with the same cases in rendered frames,
# the extent around at the nearest frame moves by -0.26 px through H.264 and -0.13 px through mp4v (median of 19,
# benchmarks/lateral_rim.py --depths, seed 50); 0.3 px brought BCA's coverage at DN >= 200 in circular pipes to
# 95 % on seed 43's rows (--table --codec-u 0 0.3; 0 px: 84 %), the shortening left in the median z (-0.46).
# On a fresh seed (47) 91.8 % (Wilson 84.0-96.0 %) with all 7 misses low: the codec's shortening is one-sided,
# now and then over a pixel, which no symmetric term covers. That was the benchmark's transcode (MPEG-4 Part 2
# re-encoded) and, mostly, an opening's rim placed inside it where its rays ran into the water: written once and
# with the rim's wall level beside it, BCA held 98.7 % with this term on a fresh seed (51), and H.264 is validated
# for BCA (``connections.VALIDATED_CODECS``; docs/measurement.md, "H.264 written once").
H264 = frozenset({"avc1", "h264", "x264", "avc3"})
# MPEG-2 (the .mpg of many German deliveries; its FourCCs as OpenCV reads them): no figure measured on it, so the
# largest known, as a codec without a figure gets for a displaced joint; no code from the image alone is validated
# in it yet (``benchmarks/automatic_connections.py --codec mpeg2`` writes it at 6 Mbit/s, for the benchmark to come)
MPEG2 = frozenset({"mpg2", "mp2v", "mpeg", "m2v1"})
CODEC_EDGE_U_PX: dict[str, float] = ({fourcc: 0.2 for fourcc in MPEG4_PART2} | {fourcc: 0.3 for fourcc in H264}
                                     | {fourcc: 0.3 for fourcc in MPEG2})
# An opening's rim (BCA) is placed where the blur that drew it in is taken back (``lateral._unblurred_rim``, since
# 2026-12-06), the codec's added blur with the rest: its shortening, which the figures above stood in for, is
# modelled, and what a codec leaves in the rim is its blocks' scatter alone. Set on seed 52's rows
# (``automatic_connections.py --table --codec-u``), against the terms the generator draws (the certificate's own
# are not: the frames are rendered with its estimates), then checked on a fresh seed (docs/measurement.md,
# "The codec's term for an opening's rim"). H.264 keeps its edge figure (under 0.2 px its coverage fell below 93 %)
# and MPEG-2, without a figure, the largest known, as above.
CODEC_RIM_U_PX: dict[str, float] = CODEC_EDGE_U_PX | {fourcc: 0.1 for fourcc in MPEG4_PART2}
# A displaced joint's ends are placed where the blur is taken back too (``joint_ends._blur``, ``blurred_gap``), so
# what a codec leaves in them is read on them: the same cases' frames rendered again without a codec, the error in
# the video less that in the rendered frame (``benchmarks/automatic_joints.py --rendered 150``, seed 354, 448
# frames of 150 cases; docs/measurement.md, "A joint's codec term in the video's pixels"). What the codec does
# depends on how large the feature is where the codec works, in the recorded video's pixels: each figure is by band
# of the two points' separation there [video px] (the gap's width along the wall, the step across the pipe) and in
# video px, spread by the undistortion into the ideal image (``joints._codec_u``). A wide-angle lens crowds a
# joint near the frame's edge into fewer video pixels (SYN-720x576: 0.63 video px per ideal px 300 px out), as a
# large pipe's nearest frames show it: until 2026-12-07 (third session) the figures were by the size in the ideal
# image, and H.264's DN 800-1000 gaps, narrowed by 0.69 px (DN 300-600: 0.07 px), held 89 % over five seeds
# (``automatic_joints.py --strata``).
# The gap's figure is the part of the shift the frames of one approach share (the case's mean over its frames,
# less what each frame's own part puts into it: ``shared_and_own``), to the nearest 0.05 px, at least 0.05 px:
# each frame's own part (0.1-0.3 px) is in its rings' jackknife, which sees the codec's noise on the edges.
# H.264 narrows a gap under 16 video px (a macroblock) by 0.6-0.7 video px, a wider one by 0.05-0.15: its blocks
# smooth a dark line a macroblock or so across. MPEG-4 Part 2: 0.15 under 12 video px, 0.05 beyond.
# The step's figure is its shift per frame (68th percentile of its size): its shared codec part and its shared
# definition in rendered frames are alike in size, and the single edges' scatter the step takes besides
# (``joints.edge_u``) is a tenth of the gap's. A step of a few px stands hardly into the pipe: H.264 0.1 video px
# under 3, 0.2 to 6, 0.25 to 12 and 0.15 beyond; MPEG-4 Part 2 0.05 under 6 and 0.1 beyond.
# MPEG-2, without a figure, takes H.264's, the largest at every size.
Bands = tuple[tuple[float, float], ...]     # (up to this size [video px], u [video px]), by increasing size; the
                                            # last open
_H264_GAP: Bands = ((16.0, 0.7), (math.inf, 0.15))
_H264_STEP: Bands = ((3.0, 0.1), (6.0, 0.2), (12.0, 0.25), (math.inf, 0.15))
CODEC_GAP_U_PX: dict[str, Bands] = ({fourcc: ((12.0, 0.15), (math.inf, 0.05)) for fourcc in MPEG4_PART2}
                                    | {fourcc: _H264_GAP for fourcc in H264 | MPEG2})
CODEC_STEP_U_PX: dict[str, Bands] = ({fourcc: ((6.0, 0.05), (math.inf, 0.1)) for fourcc in MPEG4_PART2}
                                     | {fourcc: _H264_STEP for fourcc in H264 | MPEG2})


def _flat(table: dict[str, float]) -> dict[str, Bands]:
    return {fourcc: ((math.inf, u),) for fourcc, u in table.items()}


# which table an edge takes, by what it is (``codec_edge_u``'s ``edge``)
CODEC_U_PX: dict[str, dict[str, Bands]] = {"edge": _flat(CODEC_EDGE_U_PX), "rim": _flat(CODEC_RIM_U_PX),
                                           "gap": CODEC_GAP_U_PX, "step": CODEC_STEP_U_PX}
CODEC_FAMILIES = {"MPEG-4 Part 2": MPEG4_PART2, "H.264": H264, "MPEG-2": MPEG2}     # their names, for the reasons


def _in_band(bands: Bands, size_px: float) -> float:
    return next(u for up_to, u in bands if size_px < up_to or up_to == math.inf)


def codec_edge_u(codec: str | None, *, without_figure: float | None = 0.0, edge: str = "edge",
                 size_px: float = math.inf) -> float:
    """The standard uncertainty [px] a video codec's blocks give an edge coordinate, by the video's FourCC, what
    the edge is (``CODEC_U_PX``) and, for a joint's ends, how large the feature is in the image: ``"edge"``, an
    intruding lateral's base and tip (``CODEC_EDGE_U_PX``); ``"rim"``, an opening's rim placed where the blur was
    taken back (``CODEC_RIM_U_PX``); ``"gap"`` and ``"step"``, a displaced joint's ends, its gap's and its step's
    points (``CODEC_GAP_U_PX``, ``CODEC_STEP_U_PX``), by ``size_px``, the gap's width or the step's size in the
    recorded video [video px], the figure in video px too (``joints._codec_u`` spreads it into the ideal image).
    0 for frames not through a codec (None). A codec without a figure gets ``without_figure``: 0 where
    the code is not validated in it anyway (``connections.validation_doubt``: found, not measured); None, the
    largest figure known for that edge and size, for a code measured in any codec (a displaced joint): its blocks
    move edges too, by an amount no benchmark measured.

    >>> codec_edge_u("XVID"), codec_edge_u("XVID", edge="rim"), codec_edge_u("avc1", edge="step"), codec_edge_u(None)
    (0.2, 0.1, 0.15, 0.0)
    >>> codec_edge_u("avc1", edge="gap", size_px=9.0), codec_edge_u("avc1", edge="gap", size_px=50.0)
    (0.7, 0.15)
    >>> codec_edge_u("MJPG", edge="step", size_px=2.0, without_figure=None)
    0.1
    """
    if edge not in CODEC_U_PX:
        raise ValueError(f"edge {edge!r}: one of {', '.join(CODEC_U_PX)}")
    if not codec:
        return 0.0
    if not size_px >= 0.0:
        raise ValueError(f"size_px {size_px!r}: the feature's size in the image [px], 0 or more")
    table = CODEC_U_PX[edge]
    bands = table.get(codec.strip().lower())
    if bands is not None:
        return _in_band(bands, size_px)
    if without_figure is None:
        return max(_in_band(b, size_px) for b in table.values())
    return without_figure
