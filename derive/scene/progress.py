"""The progress bar of a scene run (derive/progress.py, shared by every stage)."""
from ..progress import Progress, Stage

__all__ = ["Progress", "Stage"]
