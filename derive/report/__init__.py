"""Reports for people: the derivation of a model as a standalone LaTeX document."""
