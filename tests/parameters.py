"""Model parameters the test modules share (plain constants: they are used at import time,
in parametrize lists and in module-level cases).  Never mutate them; build a new dict
({**UNIT_PARAMS, "g": 0.0}) for a variant."""

# The unit two-link point-mass pendulum (planar, spherical_*): by name, and as the vector in
# the models' parameter order (m1, m2, l1, l2, g).
UNIT_PARAMS = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "g": 9.81}
UNIT_VECTOR = [1.0, 1.0, 1.0, 1.0, 9.81]


def named_double_pendulum(name: str, parameters: list[str], extra: str = "") -> str:
    """A model file: a planar double pendulum of point masses m1, m2 on links l1, l2 named
    "upper" and "lower" (the points springs and loads name), then `extra` (TOML tables)."""
    links = "".join(f'[[links]]\nname = "{link}"\nchart = "planar"\nlength = "l{i}"\n'
                    f'body = {{ kind = "point", mass = "m{i}" }}\n'
                    for i, link in ((1, "upper"), (2, "lower")))
    return (f'name = "{name}"\ndimension = 2\nparameters = [{", ".join(map(repr, parameters))}]\n'
            .replace("'", '"') + links + extra)
