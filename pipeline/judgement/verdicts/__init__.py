"""Verdicts a utility acts on: the contractor's log checked against the measurement, the surveyed length.

``log_check``: the normalised error E_n of a logged quantification against
the measured one, with the logged value's resolution. ``survey``: the range
the video covers against the header and the node rows of the log.
Condition grades are in ``pipeline.judgement.grading``.
"""
