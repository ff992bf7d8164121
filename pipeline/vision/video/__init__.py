"""Video ingest: reading and checking videos, the overlay chainage, undistortion."""
