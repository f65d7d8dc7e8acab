"""
A composite path
================

A path of straight lines and arcs (``kind = "path"``) or through waypoints with fillets
(``kind = "waypoints"``). ``psi`` is the arc length of the closest point, ``phi`` the signed
distance; both are closed forms per piece and compile to C. Here 40 links follow an S-shaped
path, starting from a zig-zag laid link by link along it (``start.kind = "follow"``).
"""
import coordarm
from coordarm import Path

path = Path((0.3, -0.2), 0.4, [{"line": 0.5}, {"arc": 1.0, "radius": 0.6}, {"line": 1.0}])
phi, psi = path.functions()([0.8, 0.1], 0.0)       # signed distance and arc length at a point
print(f"phi = {float(phi):.4f} m, psi = {float(psi):.4f} m, point at s = 1.2 m: {path.point_at(1.2)}")

# %%
# The same as a scenario: tables as a TOML file holds them.
duration = 8.0   # [s]
scenario = coordarm.Scenario.from_dict({
    "name": "s_path",
    "chain": {"links": 40, "link_length": 0.05},
    "curve": {"kind": "path", "start": [0.0, 0.0], "heading": 0.0,
              "segments": [{"line": 0.6}, {"arc": 1.2, "radius": 0.8}, {"arc": -1.2, "radius": 0.8}, {"line": 1.0}]},
    "control": {"gain": 2.0, "speed": 0.1},
    "start": {"kind": "follow", "beta": 1.1},
    "run": {"duration": duration, "step": 0.002},
    "figures": {"stages": [0, duration / 2, duration]},
})
result = coordarm.run_scenario(scenario, log="logs/s_path.mcap", overwrite=True)
print(*result.lines, sep="\n")           # what `coordarm run` prints
