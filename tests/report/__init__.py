"""The LaTeX report, compiled and read back."""
