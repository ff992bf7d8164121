"""Tuning constants shared by the contour modules (first pose, ring fit, entry points, single stills)."""

INLIER_PX = 2.0             # gate on a ring point's reprojection residual [px]
MIN_CURVE_POINTS = 30       # ridge curves shorter than this are texture
MIN_RING_POINTS = 40        # fewest points of a ring (or of a curve taken for one)
MIN_RING_COVERAGE_DEG = 90.0    # least arc [deg] over which a ring (or a curve taken for one) is seen
MIN_BEST_COVERAGE_DEG = 180.0   # a confident pose needs one ring seen over at least this arc [deg]; a ring seen
                                # over less is too little to judge its shape
