"""
The introduction axis (rail)
============================

``[chain] base = {kind = "rail", ...}`` adds a prismatic joint ``d`` that slides the base along
a rail. The extra output is the body's span along the path, held or commanded by
``[control] span``. On a straight path along the rail the law gives ``d_dot = v*`` with every
revolute joint at rest: the compact body travels beyond its own length. The ``thread`` preset
(60 links, an S-shaped waypoints path through the openings of two walls) shows it.
"""
import coordarm
from coordarm import CoordinatingController, Line, PlanarChain

chain = PlanarChain(links=12, link_length=0.1, base="rail", rail_angle=0.3, rail_limits=(0.0, 5.0))
ctrl = CoordinatingController(chain, Line(angle=0.3), gain=2.0, speed=0.17)
out = ctrl.evaluate(chain.zigzag(1.2, heading=0.3, d=0.4), 0.0)
print(out["u"][0], out["sigma"], out["rail_margin"])     # d_dot = v* = 0.17, the span, 1.0

# %%
# The ``thread`` preset, shortened:
duration = 18.0   # [s]
result = coordarm.run_scenario("thread", duration=duration, log="logs/thread.mcap", overwrite=True)
print(*result.lines, sep="\n")           # what `coordarm run` prints
