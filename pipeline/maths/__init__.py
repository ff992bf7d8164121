"""The maths: the GUM engine (``metrology``) and the cross-section profiles (``profiles``)."""
