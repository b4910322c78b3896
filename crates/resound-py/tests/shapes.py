"""What the tests solve and simulate: shapes built in code, a small scene; no files."""

import numpy as np


def box(x=0.08, y=0.06, z=0.05):
    """A closed box surface centred at the origin: vertices (8, 3), triangles (12, 3)."""
    v = np.array([[sx * x / 2, sy * y / 2, sz * z / 2]
                  for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    idx = lambda sx, sy, sz: (sx > 0) * 4 + (sy > 0) * 2 + (sz > 0)
    t = []
    for axis in range(3):
        for s in (-1, 1):
            corners = []
            for a in (-1, 1):
                for b in (-1, 1):
                    c = [0, 0, 0]
                    c[axis] = s
                    o = [k for k in range(3) if k != axis]
                    c[o[0]], c[o[1]] = a, b
                    corners.append(idx(*c))
            p00, p01, p10, p11 = corners
            tri = [[p00, p10, p11], [p00, p11, p01]]
            # Outward: (p10 - p00) x (p11 - p00) along +axis * s.
            n = np.cross(v[p10] - v[p00], v[p11] - v[p00])
            if n[axis] * s < 0:
                tri = [[a, c, b] for a, b, c in tri]
            t += tri
    return v, np.array(t, dtype=np.uint32)


# A steel ball rolling off onto a wooden table (a scene file's text).
SCENE_TOML = """
duration = 0.6
seed = 3
[listener]
position = [0.0, 0.3, 0.5]
[[body]]
name = "table"
fixed = true
shape = { box = [0.6, 0.04, 0.4] }
material = "preset:wood"
density = 700
position = [0.0, -0.02, 0.0]
modes = 12
[[body]]
name = "ball"
shape = { sphere = 0.02 }
material = "preset:steel"
density = 7850
position = [0.0, 0.22, 0.0]
velocity = [0.3, 0.0, 0.0]
modes = 8
"""
