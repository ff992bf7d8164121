"""Reproduction of the source paper (Martins, Almeida, Ribeiro, ACTA IMEKO 2020)."""
