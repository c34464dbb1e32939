"""The seed papers' formulas, their errata and the independent physics checks."""
