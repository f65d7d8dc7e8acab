"""
A parameter sweep
=================

For which link counts and speeds does a task complete, and with what margins? ``coordarm.sweep``
(``coordarm sweep`` on the command line) runs a scenario at every point of a grid, on a Dask
cluster: ``client=None`` starts a local one with a worker process per core, ``"tcp://host:8786"``
uses an existing cluster, ``"serial"`` runs in this process (used here). One row per point.
"""
import matplotlib.pyplot as plt

import coordarm

duration = 10.0   # [s]

df = coordarm.sweep("line", vary={"links": [8, 12, 16, 24], "speed": [0.05, 0.1, 0.2], "run.duration": [duration]},
                    client="serial", out="logs/line_sweep")
print(df[["links", "speed", "outcome", "stop_time", "min_longitudinal"]])

# %%
# A short chain pushed fast is stretched before the run is over: the run stops ahead of the
# longitudinal singularity (outcome ``singularity``).
fig, ax = plt.subplots(figsize=(6, 3.2))
for speed, rows in df.groupby("speed"):
    ax.plot(rows["links"], rows["min_longitudinal"], "o-", label=f"v* = {speed} m/s")
ax.set_xlabel("links")
ax.set_ylabel("smallest longitudinal margin")
ax.legend()
fig.tight_layout()
