"""The ground floor: errors, input limits, atomic writes, text and number helpers. Imports nothing of pipegauge."""
