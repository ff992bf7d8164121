"""Orchestration shell: Prefect flows and the command line. Calls ``pipeline``."""
