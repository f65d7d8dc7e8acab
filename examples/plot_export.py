"""
Standalone C: export and the example program
============================================

``coordarm export`` (here :func:`coordarm.export_law`) writes a scenario's law as plain C that
needs nothing of Python or CasADi at run time: ``coordarm_law.c``/``.h`` (an allocation-free,
reentrant API), a ``Makefile`` and ``example.c``, a fixed-step RK4 loop that prints
``t, q, u, outputs``. Here it is built with ``make`` and run, and its trajectory drawn.
"""
import subprocess

import matplotlib.pyplot as plt
import numpy as np

import coordarm

steps = 2000

scenario = coordarm.load_scenario("line")
ctrl = scenario.controller()
export = coordarm.export_law(ctrl, scenario.start(ctrl), "logs/line_law", step=0.001, duration=steps * 0.001)
print(sorted(p.name for p in export.directory.iterdir()))
subprocess.run(["make", "-s", "-C", "logs/line_law"], check=True)
text = subprocess.run(["logs/line_law/example", str(steps)], check=True, capture_output=True, text=True).stdout
rows = np.array([[float(v) for v in line.split()] for line in text.splitlines() if line[:1].isdigit()])
print(text.splitlines()[0][:120], "...")

# %%
# The first joints' angles as the C program integrated them (columns ``t, q_1..q_64, u, outputs``):
fig, ax = plt.subplots(figsize=(6, 3.2))
for j in range(1, 5):
    ax.plot(rows[:, 0], rows[:, j], label=f"q_{j}")
ax.set_xlabel("t [s]")
ax.set_ylabel("[rad]")
ax.legend()
fig.tight_layout()
