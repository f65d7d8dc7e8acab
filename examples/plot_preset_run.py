"""
A preset run
============

Run the ``line`` preset, the same as ``coordarm run line``: 64 links start as a compact
zig-zag on a line that swings slowly; every link's central point stays on the line while the
end point advances at ``v* = 0.1`` m/s. ``run_scenario`` writes the MCAP log and two figures
(the robot at several times, and the deviations against ``e(0) exp(-K t)``) and returns a
result instead of printing.
"""
import coordarm

duration = 20.0   # [s]

result = coordarm.run_scenario("line", duration=duration, log="logs/line.mcap", overwrite=True)
print(result.outcome, result.exit_status)       # completed 0
print(*result.lines, sep="\n")           # what `coordarm run` prints
