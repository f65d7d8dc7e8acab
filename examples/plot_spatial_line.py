"""
A spatial chain on a moving line: line3d
========================================

``[chain] joints = "universal"`` gives every joint two angles: the paper's law in space. The
``line3d`` preset: 64 links on a line that swings out of the base plane while the commanded
roll turns the fold plane by 0.4 rad. The deviations fall like ``exp(-K t)``, ``s`` tracks
``v*`` and the roll its command.
"""
import coordarm

duration = 12.0   # [s]

result = coordarm.run_scenario("line3d", duration=duration, log="logs/line3d.mcap", overwrite=True)
print(*result.lines, sep="\n")           # what `coordarm run` prints
