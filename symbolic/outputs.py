"""The packed output vector of the control law: one table, read by every layer.

The law ``(q, t) -> outputs`` returns the rows of :data:`LAW_OUTPUTS` in table order; the
generated C packs them into one ``double`` vector in the same order (its offsets are
:func:`offsets`); the ctypes loader splits that vector with :func:`split`; the run log writes
each row that names a ``channel`` into that channel, and replay reads it back by the same
name. Adding an output to the law is adding a row here (and computing it in the law).

Imports nothing (not even numpy), so the command line can read it without loading CasADi.
"""
from __future__ import annotations

from typing import Any

from .records import record


@record(frozen=True)
class Output:
    """One output of the control law.

    Attributes
    ----------
    name : str
        Its one name: the CasADi output name, the key of ``evaluate()``, the
        :class:`~coordarm.simulation.run.Run` attribute and the log field.
    per_link, extra : int
        Width ``per_link * m + extra`` for a chain of ``m`` links (a scalar: ``(0, 1)``).
    unit : str
        Physical unit (``"-"`` for dimensionless, ``"rad/s"`` for controls with B = I).
    channel : str or None
        Key of the log channel (:func:`coordarm.simulation.log_schemas.numeric_channels`)
        the output is written to at every logged step, or None if it is not logged.
    description : str
        What it is.
    """

    name: str
    per_link: int
    extra: int
    unit: str
    channel: str | None
    description: str

    @property
    def scalar(self) -> bool:
        """True for a scalar (width 1 whatever the number of links)."""
        return self.per_link == 0 and self.extra == 1

    def width(self, m: int) -> int:
        """Number of doubles of this output for ``m`` links.

        Parameters
        ----------
        m : int
            Number of links.

        Returns
        -------
        int
            ``per_link * m + extra``.
        """
        return self.per_link * m + self.extra


#: The law's outputs, in the order of the CasADi Function and of the packed C vector.
LAW_OUTPUTS: tuple[Output, ...] = (
    Output("u", 1, 0, "rad/s", "joint_state", "control u = B^-1 qdot (joint rates for B = I)"),
    Output("e", 1, -1, "m", "task_state", "deviations e^2..e^m of the link centres from the curve"),
    Output("s", 0, 1, "m", "task_state", "arc length s^m of the end point along the curve"),
    Output("link_margins", 1, -1, "-", "margins", "link margins of links 2..m (0: link across the curve)"),
    Output("longitudinal", 0, 1, "-", "margins",
           "longitudinal margin (0: the end point cannot be pushed along the curve)"),
    Output("longitudinal_pivot", 0, 1, "m/rad", None, "signed longitudinal pivot of the s equation"),
    Output("v_scale", 0, 1, "-", "task_state",
           "the speed governor's factor on v* (1 without the governor; 0 at the longitudinal threshold)"),
)

#: Extra outputs of a chain on a rail (introduction axis), after :data:`LAW_OUTPUTS`; there ``u``
#: has ``m + 1`` entries, ``d_dot`` [m/s] first (see :func:`outputs_of`).
RAIL_LAW_OUTPUTS: tuple[Output, ...] = (
    Output("sigma", 0, 1, "m", "task_state", "span of the body along the path, psi(y^m) - psi(y^1)"),
    Output("rail_margin", 0, 1, "-", "margins",
           "rail margin |grad psi(y^1) . rail| / |grad psi(y^1)| (0: the rail stands across the path)"),
)

#: The outputs of the spatial law (:class:`~coordarm.symbolic.spatial_controller.SpatialController`,
#: universal joints), in order; a layout of their own (the planar tables above are unchanged). ``u`` holds
#: ``(a_1', b_1', ..., a_m', b_m')``, ``e`` the deviations ``(e^2_1, e^2_2, e^3_1, ...)``.
SPATIAL_LAW_OUTPUTS: tuple[Output, ...] = (
    Output("u", 2, 0, "rad/s", "joint_state", "joint rates (a_1', b_1', ..., a_m', b_m') (B = I)"),
    Output("e", 2, -2, "m", "task_state", "normal deviations e^2_1, e^2_2, ..., e^m_2 of the link centres"),
    Output("s", 0, 1, "m", "task_state", "arc length s of the end point along the curve"),
    Output("roll", 0, 1, "rad", "task_state", "roll of the first link about the curve, atan2(n_2.d_1, n_1.d_1)"),
    Output("link_margins", 1, -1, "-", "margins",
           "smallest singular value of each link pivot over xi/2, links 2..m (0: link across the curve)"),
    Output("end_margin", 0, 1, "-", "margins", "smallest singular value of the scaled 2x2 end solve (s and roll)"),
    Output("joint_margins", 1, 0, "-", "margins", "|cos b_j| of each joint (0: the joint's own singularity)"),
)

#: Names of the law's outputs, in order.
OUTPUTS: tuple[str, ...] = tuple(o.name for o in LAW_OUTPUTS)
#: Names of the rail's extra outputs.
RAIL_OUTPUTS: tuple[str, ...] = tuple(o.name for o in RAIL_LAW_OUTPUTS)
#: The outputs that are scalars (the others are vectors over links).
SCALAR_OUTPUTS: tuple[str, ...] = tuple(o.name for o in LAW_OUTPUTS + RAIL_LAW_OUTPUTS if o.scalar)
#: The outputs kept at every sample of a run and logged (those with a channel); the closed-loop RK4
#: step returns them (the law at the step's start) after ``q_next``.
RUN_OUTPUTS: tuple[str, ...] = tuple(o.name for o in LAW_OUTPUTS if o.channel is not None)
#: Names of the spatial law's outputs, in order.
SPATIAL_OUTPUTS: tuple[str, ...] = tuple(o.name for o in SPATIAL_LAW_OUTPUTS)
#: The spatial outputs that are scalars.
SPATIAL_SCALAR_OUTPUTS: tuple[str, ...] = tuple(o.name for o in SPATIAL_LAW_OUTPUTS if o.scalar)
#: The spatial outputs kept at every sample of a run (those with a channel).
SPATIAL_RUN_OUTPUTS: tuple[str, ...] = tuple(o.name for o in SPATIAL_LAW_OUTPUTS if o.channel is not None)


def by_name(name: str) -> Output:
    """The row of :data:`LAW_OUTPUTS` called ``name``.

    Parameters
    ----------
    name : str
        Output name (one of :data:`OUTPUTS`).

    Returns
    -------
    Output
        Its row.

    Raises
    ------
    KeyError
        No output has that name.
    """
    for o in LAW_OUTPUTS:
        if o.name == name:
            return o
    raise KeyError(f"no law output named {name!r} (outputs: {', '.join(OUTPUTS)})")


def outputs_of(rail: bool = False) -> tuple[Output, ...]:
    """The rows of the law's outputs: :data:`LAW_OUTPUTS`, and on a ``rail`` ``u`` one wider plus
    :data:`RAIL_LAW_OUTPUTS`.

    Parameters
    ----------
    rail : bool
        A chain on a rail.

    Returns
    -------
    tuple of Output
        In packed order.
    """
    return _with_rail(LAW_OUTPUTS, 1) if rail else LAW_OUTPUTS


def packed_width(m: int, rail: bool = False) -> int:
    """Length of the packed output vector for ``m`` links (``3 m + 2``; ``3 m + 5`` on a rail).

    Parameters
    ----------
    m : int
        Number of links.
    rail : bool
        The chain's base moves on a rail.

    Returns
    -------
    int
        Number of doubles.
    """
    return sum(o.width(m) for o in outputs_of(rail))


def offsets(m: int, rail: bool = False) -> dict[str, tuple[int, int]]:
    """``name -> (start, width)`` of each output in the packed vector for ``m`` links (on a ``rail``).

    Parameters
    ----------
    m : int
        Number of links.
    rail : bool
        The chain's base moves on a rail.

    Returns
    -------
    dict of str to (int, int)
        Start index and width of each output, in packing order.
    """
    return _offsets_of(outputs_of(rail), m)


def split(packed: Any, m: int, rail: bool = False) -> dict[str, Any]:
    """Split packed output rows into a dict keyed by :data:`OUTPUTS`.

    Parameters
    ----------
    packed : ndarray, shape (packed_width(m),) or (n, packed_width(m))
        One packed row or a block of rows (a view is returned into it; copy if it is reused).
    m : int
        Number of links.
    rail : bool
        A chain on a rail (``u`` one wider, ``sigma`` and ``rail_margin`` at the end).

    Returns
    -------
    dict
        Vectors as ``(..., width)`` slices; scalars as a float (one row) or an ``(n,)`` array.

    Raises
    ------
    ValueError
        The last axis is not ``packed_width(m)`` long.
    """
    return _split_rows(packed, outputs_of(rail), m, "packed outputs")


def spatial_outputs_of(rail: bool = False) -> tuple[Output, ...]:
    """The rows of the spatial law's outputs: :data:`SPATIAL_LAW_OUTPUTS`, and on a ``rail`` ``u`` one wider
    (``d_dot`` [m/s] first) plus :data:`RAIL_LAW_OUTPUTS` (``sigma``, ``rail_margin``) at the end.

    Parameters
    ----------
    rail : bool
        A spatial chain on a rail (feed axis).

    Returns
    -------
    tuple of Output
        In packed order.
    """
    return _with_rail(SPATIAL_LAW_OUTPUTS, 2) if rail else SPATIAL_LAW_OUTPUTS


def spatial_packed_width(m: int, rail: bool = False) -> int:
    """Length of the packed output vector of the spatial law for ``m`` links (``6 m``; ``6 m + 3`` on a rail).

    Parameters
    ----------
    m : int
        Number of links.
    rail : bool
        A chain on a rail.

    Returns
    -------
    int
        Number of doubles: the widths of :func:`spatial_outputs_of` summed.
    """
    return sum(o.width(m) for o in spatial_outputs_of(rail))


def spatial_offsets(m: int, rail: bool = False) -> dict[str, tuple[int, int]]:
    """``name -> (start, width)`` of each spatial output in the packed vector for ``m`` links.

    The generated C of a :class:`~coordarm.symbolic.spatial_controller.SpatialController` packs the law
    (and each row ``D[k]`` of a chunk) in this layout: the rows of :func:`spatial_outputs_of` in order,
    which are also the run outputs (every spatial output is logged).

    Parameters
    ----------
    m : int
        Number of links.
    rail : bool
        A chain on a rail (``u`` one wider, ``sigma`` and ``rail_margin`` at the end).

    Returns
    -------
    dict of str to (int, int)
        Start index and width of each output, in packing order.
    """
    return _offsets_of(spatial_outputs_of(rail), m)


def spatial_split(packed: Any, m: int, rail: bool = False) -> dict[str, Any]:
    """Split packed spatial output rows into a dict keyed by the names of :func:`spatial_outputs_of`.

    Parameters
    ----------
    packed : ndarray, shape (spatial_packed_width(m, rail),) or (n, spatial_packed_width(m, rail))
        One packed row or a block of rows (views are returned into it).
    m : int
        Number of links.
    rail : bool
        A chain on a rail.

    Returns
    -------
    dict
        Vectors as ``(..., width)`` slices; scalars as a float (one row) or an ``(n,)`` array.

    Raises
    ------
    ValueError
        The last axis is not ``spatial_packed_width(m, rail)`` long.
    """
    return _split_rows(packed, spatial_outputs_of(rail), m, "packed spatial outputs")


def _with_rail(rows: tuple[Output, ...], u_rows: int) -> tuple[Output, ...]:
    """``rows`` on a rail: ``u`` (``u_rows`` rows) one wider, ``d_dot`` [m/s] first; :data:`RAIL_LAW_OUTPUTS` last."""
    u = rows[0]
    return (Output(u.name, u_rows, 1, u.unit, u.channel, u.description + "; d_dot [m/s] first"),
            *rows[1:], *RAIL_LAW_OUTPUTS)


def _offsets_of(rows: tuple[Output, ...], m: int) -> dict[str, tuple[int, int]]:
    """``name -> (start, width)`` of each of ``rows`` packed in order for ``m`` links."""
    out, start = {}, 0
    for o in rows:
        out[o.name] = (start, o.width(m))
        start += o.width(m)
    return out


def _split_rows(packed: Any, rows: tuple[Output, ...], m: int, label: str) -> dict[str, Any]:
    """``packed`` (last axis the widths of ``rows`` summed) split by row; ``label`` names it in the error."""
    width = sum(o.width(m) for o in rows)
    if packed.shape[-1] != width:
        raise ValueError(f"{label}: last axis of {packed.shape[-1]}, expected {width} for {m} links")
    result: dict[str, Any] = {}
    offs = _offsets_of(rows, m)
    for o in rows:
        start, w = offs[o.name]
        if o.scalar:
            v = packed[..., start]
            result[o.name] = float(v) if v.ndim == 0 else v
        else:
            result[o.name] = packed[..., start:start + w]
    return result
