"""Scene files and derive run: loading, planning to an accuracy target, outputs."""
