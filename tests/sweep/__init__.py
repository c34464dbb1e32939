"""Sweeps on Dask."""
