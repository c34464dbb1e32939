"""Model parameters the test modules share (plain constants: they are used at import time,
in parametrize lists and in module-level cases).  Never mutate them; build a new dict
({**UNIT_PARAMS, "g": 0.0}) for a variant."""

# The unit two-link point-mass pendulum (planar, spherical_*): by name, and as the vector in
# the models' parameter order (m1, m2, l1, l2, g).
UNIT_PARAMS = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
UNIT_VECTOR = [1.0, 1.0, 1.0, 1.0, 9.81]
