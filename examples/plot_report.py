"""
A singularity report
====================

``coordarm report`` (here :func:`~coordarm.analysis.report_outputs.report_of`) shows every
singularity margin over time, the worst link, the first time each threshold was crossed and
which margin crossed before ``|u|`` exceeded 10x its nominal value, with the linearised error
dynamics. Given a scenario it simulates with the stops off, so a blow-up shows: here the
``line`` preset run for 60 s, long enough to stretch the chain towards its longitudinal
singularity.
"""
import json

from coordarm.analysis.report_outputs import report_of

duration = 60.0   # [s]

report = report_of("line", "logs/line_report", duration=duration, yes=True)
print(report.path.read_text()[:1500])
summary = json.loads((report.path.parent / "report.json").read_text())
print("longitudinal margin:", summary["margins"]["longitudinal"])
