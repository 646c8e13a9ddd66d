"""Tick locations computed once per axes geometry while a figure is saved (issue 24).

Between its layout pass and its draw, matplotlib asks an axis for its tick locations
about eleven times (each tick-label, axis-label, title and spine measurement updates
the ticks), and each time the locator computes them anew: the automatic locators find
the space for tick labels (a font lookup) and the steps, the log locators their
decades.  Their answer depends only on the view limits and the axes' size on the
canvas, so :class:`ViewTickLocator` keeps it for that key.  It also drops the
locations outside the view limits, which matplotlib never draws but for which it
creates a tick (three lines, two labels) on the first pass: 30 % of the report's
ticks.

Imported by :func:`servokit._figures.save_figure` when it saves (matplotlib loaded).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.ticker import Locator

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["ViewTickLocator", "cache_tick_locations"]


class ViewTickLocator(Locator):
    """A locator answering as ``inner`` within the view limits, computed once per view
    limits, axes size and dpi.

    Parameters
    ----------
    inner : matplotlib.ticker.Locator
        An automatic locator (``MaxNLocator``, ``AutoLocator``, ``LogLocator``,
        ``MultipleLocator``): its locations are positions only, never indexes into a
        list of labels (a ``FixedLocator``'s are, for a ``FixedFormatter``).
    """

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self._key: tuple[float, ...] | None = None
        self._locs = np.empty(0)

    def set_axis(self, axis: Any) -> None:
        """Answer for the axis the wrapped locator answers for (of shared axes, the one
        it was set on), ``axis`` if it has none."""
        if getattr(self.inner, "axis", None) is None:
            self.inner.set_axis(axis)
        self.axis = self.inner.axis

    def __call__(self) -> np.ndarray:
        """The wrapped locator's locations inside the view limits (all if fewer than 2)."""
        axis = self.axis
        vmin, vmax = sorted(axis.get_view_interval())
        box = axis.axes.bbox
        key = (vmin, vmax, box.width, box.height, axis.axes.get_figure(root=True).dpi)
        if key != self._key:
            locs = np.asarray(self.inner(), dtype=float)
            # a relative margin far below a pixel: matplotlib draws the ticks within
            # 1e-10 of the span, and keeps dropping those outside itself
            tol = 1e-6 * (vmax - vmin)
            inside = locs[(locs >= vmin - tol) & (locs <= vmax + tol)]
            self._locs = inside if len(inside) >= 2 else locs
            self._key = key
        return self._locs.copy()

    def tick_values(self, vmin: float, vmax: float) -> Any:
        """As the wrapped locator."""
        return self.inner.tick_values(vmin, vmax)

    def view_limits(self, vmin: float, vmax: float) -> Any:
        """As the wrapped locator (autoscaling with round numbers)."""
        return self.inner.view_limits(vmin, vmax)

    def nonsingular(self, v0: float, v1: float) -> Any:
        """As the wrapped locator (autoscaling of degenerate limits)."""
        return self.inner.nonsingular(v0, v1)

    def set_params(self, **kwargs: Any) -> None:
        """As the wrapped locator; forget the kept locations."""
        self.inner.set_params(**kwargs)
        self._key = None


def cache_tick_locations(fig: Figure) -> int:
    """Wrap the automatic tick locators of ``fig``'s axes in :class:`ViewTickLocator`.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        A figure about to be laid out and drawn (then closed).

    Returns
    -------
    int
        The number of locators wrapped.
    """
    from matplotlib.ticker import FixedFormatter, LogLocator, MaxNLocator, MultipleLocator

    automatic = (MaxNLocator, LogLocator, MultipleLocator)
    wrapped = 0
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for major in (True, False):
                locator = axis.get_major_locator() if major else axis.get_minor_locator()
                formatter = axis.get_major_formatter() if major else axis.get_minor_formatter()
                # shared axes share their locators: wrap each once
                if not isinstance(locator, automatic) or isinstance(formatter, FixedFormatter):
                    continue
                wrapper = ViewTickLocator(locator)
                if major:
                    axis.set_major_locator(wrapper)
                else:
                    axis.set_minor_locator(wrapper)
                wrapped += 1
    return wrapped
