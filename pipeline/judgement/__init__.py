"""Judging measurements: the contractor's log checked (``verdicts``) and condition grades (``grading``)."""
