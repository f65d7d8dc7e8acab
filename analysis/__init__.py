"""Analysis of runs and logs: margins, linearised error dynamics (python-control), replay, reports,
baselines comparison, figures. Imports the layers below it (simulation, generated, symbolic), never the command line."""
