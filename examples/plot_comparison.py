"""
Coordinating control against the classic baselines
==================================================

``coordarm compare`` runs one scenario under the coordinating law and the classic baselines on
the same task: ``pinv`` (resolved-rate control of the end point with the pseudoinverse and a
null-space centering term), ``dls`` (the same, damped) and, on a rail, ``ftl``
(follow-the-leader). All put the end point where it should be; only the coordinating law
keeps the *body* on the curve.
"""
from pathlib import Path

import coordarm
from coordarm.analysis.compare import compare, text_table, write_outputs

duration = 8.0   # [s]

scenario = coordarm.load_scenario("hole")
scenario = coordarm.Scenario.from_dict({**scenario.spec, "run": {**scenario.spec["run"], "duration": duration}},
                                       source="hole")
results = compare(scenario, ["coordinating", "pinv", "dls"])
print(text_table(results))
files = write_outputs(scenario, results, Path("logs/hole_compare"))
