"""Stage 3, verification: every printed formula of the seeds against the derivation."""
