"""
A log replayed in an analysis script
====================================

A run's MCAP log holds everything needed to analyse it later: the scenario (so the controller
can be rebuilt), every step's ``q``, ``u``, deviations, ``s`` and margins, and the outcome.
:func:`coordarm.load_log` reads it back as numpy arrays; here the margins are recomputed from
the logged configurations with the rebuilt controller and checked against the logged ones.
"""
import matplotlib.pyplot as plt
import numpy as np

import coordarm

duration = 10.0   # [s]

coordarm.run_scenario("arc", duration=duration, log="logs/arc.mcap", overwrite=True, figures=False)
rep = coordarm.load_log("logs/arc.mcap")
print(rep.outcome["status"], rep.q.shape, "problems:", rep.problems)
ctrl = rep.scenario.controller()                      # the controller that made the run

# %%
# The smallest link margin, as logged and recomputed from ``q`` at a few samples:
idx = np.linspace(0, len(rep.t) - 1, 12).astype(int)
again = [np.min(ctrl.evaluate(rep.q[i], rep.t[i])["link_margins"]) for i in idx]
fig, ax = plt.subplots(figsize=(6, 3.2))
ax.plot(rep.t, np.min(rep.link_margins, axis=1), label="logged")
ax.plot(rep.t[idx], again, "o", label="recomputed from q")
ax.plot(rep.t, rep.longitudinal, label="longitudinal margin")
ax.set_xlabel("t [s]")
ax.set_ylabel("margin")
ax.legend()
fig.tight_layout()
