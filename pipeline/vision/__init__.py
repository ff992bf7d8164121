"""Seeing the pipe: the contour in ideal images (``contour``) and the video, its overlay and track (``video``)."""
