"""
A user-defined 3-D path
=======================

A spatial chain follows any :class:`coordarm.Path3D`: straight pieces and arcs that turn by an
angle towards ``cos(bank) n_1 + sin(bank) n_2`` of the frame transported along the path. Here
a path of your own that climbs out of the base plane, built in Python and run directly with
:func:`coordarm.simulate`; the figure is drawn from the run.
"""
from pathlib import Path

import numpy as np

import coordarm
from coordarm import Path3D, SpatialChain, SpatialController
from coordarm.simulation.figures3d import plot_spatial_stages

duration = 8.0   # [s]

path = Path3D(start=(-0.2, 0.0, 0.0), direction=(1, 0, 0), normal=(0, 1, 0),
              segments=[{"line": 0.8}, {"arc": 0.8, "radius": 1.0, "bank": np.pi / 2}, {"line": 1.0}])
chain = SpatialChain(links=40, link_length=0.05)
q0 = chain.zigzag(0.9)
ctrl = SpatialController(chain, path, gain=2.0, speed=0.05, start=q0)
run = coordarm.simulate(ctrl, q0, duration, 0.002)
print(run.info["stopped"], "final max|e| =", np.max(np.abs(run.e[-1])))
Path("logs").mkdir(exist_ok=True)
plot_spatial_stages(run, ctrl, "logs/my_path3d_stages.png")
