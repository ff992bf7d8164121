"""Condition reports: measurement thumbnails (drawn while the video is at hand) and PDFs rendered from the dataset."""

from pipeline.reports.inspection_report import render_inspection_report, report_file_name
from pipeline.reports.summary_report import render_night_summary

__all__ = ["render_inspection_report", "report_file_name", "render_night_summary"]
