"""Time series: one scalar entity per series, named once with a static ``SeriesLines``."""

from __future__ import annotations

import math

import rerun as rr


class SeriesWriter:
    """Logs scalars to entities, giving each entity its legend name on first use.

    Parameters
    ----------
    rec : rerun.RecordingStream
        Where to log.
    """

    def __init__(self, rec: rr.RecordingStream) -> None:
        self._rec = rec
        self._named: set[str] = set()

    def scalar(self, entity: str, value: float, name: str | None = None) -> bool:
        """Log ``value`` at the current time on ``entity``; NaN is skipped.

        Parameters
        ----------
        entity : str
            Entity path of the series.
        value : float
            The value; NaN means "not available" and logs nothing.
        name : str, optional
            Legend name, logged once per entity (default: the last path part).

        Returns
        -------
        bool
            Whether a value was logged.
        """
        value = float(value)
        if math.isnan(value):
            return False
        if entity not in self._named:
            label = name if name is not None else entity.rsplit("/", 1)[-1]
            self._rec.log(entity, rr.SeriesLines(names=[label]), static=True)
            self._named.add(entity)
        self._rec.log(entity, rr.Scalars(value))
        return True
