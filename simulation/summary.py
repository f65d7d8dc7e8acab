"""The human-readable summary of a run: tracking, margins, joints, contacts and clearances, one line each."""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:   # numpy and the run module load only when a summary is written
    from coordarm.simulation.run import Run
    from coordarm.simulation.scenario import Scenario


#: Most obstacles a spatial summary lists one by one (the closest; one line sums up the others).
CLEARANCE_LINES = 6


def summary_lines(run: Run, scenario: Scenario) -> list[str]:
    """The summary of ``run`` that ``coordarm run`` and ``coordarm replay`` print, one string per line.

    Parameters
    ----------
    run : Run
        The simulated (or replayed) run; ``run.q`` is ``(n, m)`` [rad, and m for a rail].
    scenario : Scenario
        The scenario it ran (name, source, chain, obstacles, ``[control] governor``).

    Returns
    -------
    list of str
        Scenario and link count; simulated time and steps, stop reason and backend; final max|e| [m];
        s tracking [m]; the smallest link and longitudinal margins; max|u|; the governor's slowing and
        the rail's travel when used; then :func:`physical_lines` for a full configuration. A spatial
        run: :func:`spatial_summary_lines`.
    """
    import numpy as np

    if run.layout.kind != "revolute":
        return spatial_summary_lines(run, scenario)
    s = run.summary()
    lines = [f"scenario      {scenario.name} ({scenario.source}), {run.q.shape[1] - int(scenario.chain().rail)} links"
             + (" on a rail" if scenario.chain().rail else ""),
             f"simulated     {s['duration']:.3f} s in {s['steps']} steps ({run.info.get('stopped', '?')}, "
             f"backend {run.info.get('backend', '?')})",
             f"final max|e|  {s['final_max_abs_e']:.3e} m",
             f"s tracking    max |s - (s0 + ∫v*)| = {s['max_s_tracking_error']:.3e} m",
             f"link margin   min {s['min_link_margin']:.4f} (link {s['min_link_margin_link']}, "
             f"t = {s['min_link_margin_time']:.2f} s)",
             f"longitudinal  min {s['min_longitudinal_margin']:.4f} (t = {s['min_longitudinal_margin_time']:.2f} s)",
             f"max|u|        {s['max_abs_u']:.4g}"]
    lines += rate_lines(run.info.get("joint_rates"))
    if scenario.config.control.governor:
        lines.append(f"governor      v* slowed during {run.info.get('governed', run.governed_time()):.3f} s (final v_scale {run.speed_factor()[-1]:.3g})")
    if run.sigma is not None:
        lines.append(f"rail          d from {run.q[0, 0]:.4f} to {run.q[-1, 0]:.4f} m, span sigma {run.sigma[0]:.4f} -> "
                     f"{run.sigma[-1]:.4f} m, min rail margin {np.min(run.rail_margin):.4f}")
    if run.q.shape[1] == scenario.chain().dof:
        lines += physical_lines(run, scenario)
    return lines


def rate_lines(peaks: dict | None) -> list[str]:
    """The line of the joint accelerations' peak (and the rail's ``d''``), from ``run.info["joint_rates"]``.

    Parameters
    ----------
    peaks : dict or None
        :attr:`~coordarm.simulation.joint_rates.JointRates.peaks` (None or empty: no line).

    Returns
    -------
    list of str
        ``peak |du/dt|  <value> rad/s^2 (joint j, t = ..)`` and on a rail ``, d'' <value> m/s^2``.
    """
    if not peaks or "du_dt" not in peaks:
        return []
    line = (f"peak |du/dt|  {peaks['du_dt']:.4g} rad/s² (joint {peaks['du_dt_joint']}, "
            f"t = {peaks['du_dt_time']:.3f} s)")
    if "rail_accel" in peaks:
        line += f", rail |d''| {peaks['rail_accel']:.4g} m/s² (t = {peaks['rail_accel_time']:.3f} s)"
    return [line]


def spatial_summary_lines(run: Run, scenario: Scenario) -> list[str]:
    """The summary of a spatial run (universal joints), one string per line.

    Parameters
    ----------
    run : Run
        The simulated (or replayed) run; ``run.q`` is ``(n, 2 m)`` [rad].
    scenario : Scenario
        The scenario it ran (name, source).

    Returns
    -------
    list of str
        Scenario and link count; simulated time and steps, stop reason and backend; final max|e^j| [m];
        s tracking [m]; roll tracking [rad]; the smallest link, end and joint margins; max|u| [rad/s];
        on a rail its travel, span and margin; the largest bend against its limit and the clearance to every
        obstacle (:func:`spatial_physical_lines`).
    """
    import numpy as np

    s = run.summary()
    rail = [] if run.sigma is None else [
        f"rail          d from {run.q[0, 0]:.4f} to {run.q[-1, 0]:.4f} m, span sigma {run.sigma[0]:.4f} -> "
        f"{run.sigma[-1]:.4f} m, min rail margin {np.min(run.rail_margin):.4f}"]
    return [f"scenario      {scenario.name} ({scenario.source}), {run.q.shape[1] // 2} links, universal joints"
            + (" on a rail" if run.sigma is not None else ""),
            f"simulated     {s['duration']:.3f} s in {s['steps']} steps ({run.info.get('stopped', '?')}, "
            f"backend {run.info.get('backend', '?')})",
            f"final max|e|  {s['final_max_abs_e']:.3e} m",
            f"s tracking    max |s - (s0 + ∫v*)| = {s['max_s_tracking_error']:.3e} m",
            f"roll tracking max |roll - roll*| = {s['max_roll_tracking_error']:.3e} rad",
            f"link margin   min {s['min_link_margin']:.4f} (link {s['min_link_margin_link']}, "
            f"t = {s['min_link_margin_time']:.2f} s)",
            f"end margin    min {s['min_end_margin']:.4f} (t = {s['min_end_margin_time']:.2f} s)",
            *rate_lines(run.info.get("joint_rates")),
            f"joint margin  min |cos b_j| = {s['min_joint_margin']:.4f} (joint {s['min_joint_margin_joint']}, "
            f"t = {s['min_joint_margin_time']:.2f} s)",
            f"max|u|        {s['max_abs_u']:.4g}"] + rail + spatial_physical_lines(run, scenario)


def spatial_physical_lines(run: Run, scenario: Scenario) -> list[str]:
    """The contacts an ``--allow-contact`` spatial run recorded, and per obstacle the smallest gap to a link's capsule.

    Parameters
    ----------
    run : Run
        The run (``run.q`` is ``(n, 2 m)`` [rad]).
    scenario : Scenario
        Its scenario (obstacles, capsule radius).

    Returns
    -------
    list of str
        The largest bend against its limit (a full configuration only), a contacts line when the run recorded
        any, then ``clearance 'name': min gap [m] (link, t)`` from at most 2000 evenly spread samples per obstacle
        (more than :data:`CLEARANCE_LINES` obstacles: the closest ones, in file order, then one line for the rest).
    """
    import numpy as np

    from coordarm.generated.chain_geometry import spatial_frames
    from coordarm.simulation.run import even_indices
    from coordarm.symbolic.start3d import bends_between

    chain, rows = scenario.chain(), even_indices(len(run.t), 2000)
    lines = []
    if run.q.shape[1] == chain.dof:
        rel = bends_between(spatial_frames(chain, run.q[rows])[..., 0]) / np.broadcast_to(np.asarray(scenario.config.chain.bend_limit, float),
                                                                (chain.m - 1,))
        k, j = np.unravel_index(int(np.argmax(rel)), rel.shape)
        lim = np.broadcast_to(np.asarray(scenario.config.chain.bend_limit, float), (chain.m - 1,))[j]
        lines.append(f"bends         max bend/limit = {rel[k, j]:.3f} (joint {j + 2}: {rel[k, j] * lim:.3f} rad of "
                     f"{lim:.3f}, t = {run.t[rows][k]:.2f} s)")
    contacts = run.info.get("contacts") or []
    lines += [f"contacts      {len(contacts)} distinct (allowed), first: {contacts[0]['kind']} at "
              f"t = {contacts[0]['time']:.3f} s, links {contacts[0]['links']}"] if contacts else []
    if not scenario.obstacles:
        return lines
    gaps = scenario.physical().clearances(run.q[rows], run.t[rows])
    shown_gaps = dict(sorted(gaps.items(), key=lambda kv: kv[1][0])[:CLEARANCE_LINES]) \
        if len(gaps) > CLEARANCE_LINES else gaps
    lines += [f"clearance     {name!r}: min {d:.4f} m (link {link}, t = {t:.2f} s)"
              for name, (d, t, link) in gaps.items() if name in shown_gaps]
    if len(gaps) > len(shown_gaps):
        rest = min(d for name, (d, _, _) in gaps.items() if name not in shown_gaps)
        lines.append(f"clearance     {len(gaps) - len(shown_gaps)} more obstacles, each at least {rest:.4f} m away")
    return lines


def physical_lines(run: Run, scenario: Scenario) -> list[str]:
    """Summary lines: largest joint angle against its limit, contacts, clearance per obstacle.

    Parameters
    ----------
    run : Run
        A run of the scenario's full chain (``run.q`` is ``(n, dof)``).
    scenario : Scenario
        Its scenario (joint limits, obstacles).

    Returns
    -------
    list of str
        The joint line [rad], a contacts line when the run recorded any, one clearance line [m] per obstacle
        (clearances from at most 2000 evenly spread samples).
    """
    import numpy as np

    from coordarm.simulation.run import even_indices

    chain = scenario.chain()
    qr = chain.revolute(run.q)
    rel = np.abs(qr[:, 1:])
    rel /= chain.joint_limits          # in place: one array of the run's size, not two
    k, j = np.unravel_index(int(np.argmax(rel)), rel.shape)
    lines = [f"joints        max |q_j|/limit = {rel[k, j]:.3f} (joint {j + 2}: {qr[k, j + 1]:+.3f} rad of "
             f"±{chain.joint_limits[j]:.3f}, t = {run.t[k]:.2f} s)"]
    contacts = run.info.get("contacts") or []
    if contacts:
        lines.append(f"contacts      {len(contacts)} distinct (allowed), first: {contacts[0]['kind']} at "
                     f"t = {contacts[0]['time']:.3f} s, links {contacts[0]['links']}")
    rows = even_indices(len(run.t), 2000)
    for name, (d, t, link) in scenario.physical(chain).clearances(run.q[rows], run.t[rows]).items():
        lines.append(f"clearance     {name!r}: min {d:.4f} m (link {link}, t = {t:.2f} s)")
    return lines
