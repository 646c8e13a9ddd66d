"""A design report for a user's actuator: one self-contained ``report.html`` (issue 22).

:func:`design_report` renders any of four sections, each computed from the user's data:

* :class:`FitSection` — a measured FRF against the fitted model (Bode overlay, median and
  largest relative error ``|P_model / P_measured - 1|``);
* :class:`MarginsSection` — gain, phase and delay margins of the loop ``P_v C`` for every
  plant ``v`` of a set (:func:`servokit.feedback.stability_margins`, ZOH-discretised plant
  for a discrete controller), the worst of each marked;
* :class:`SeekSection` — the seek-time histogram of a feedforward input over a plant set,
  with its worst case (and the design guarantee, when there is one);
* :class:`SensitivitySection` — ``|S| = |1 / (1 + P_v C)|`` of every plant, its peak.

The page uses the same jinja2 environment, style sheet and embedded-figure machinery
(:mod:`servokit.report.html`) as the reproduction report.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from servokit.errors import ServokitValueError
from servokit.models.modal import ModalPlant
from servokit.models.rational import RationalTF, StateSpaceData

__all__ = [
    "FitSection",
    "MarginsSection",
    "SeekSection",
    "SensitivitySection",
    "design_report",
    "loop_factors",
]


def loop_factors(plant: ModalPlant, controller: Any) -> list[Any]:
    """Factors of the loop ``P C``: the plant ZOH-discretised when ``controller`` is discrete.

    Parameters
    ----------
    plant : ModalPlant
        Plant (its delay included).
    controller : control.LTI, RationalTF or StateSpaceData
        Controller, continuous or discrete.

    Returns
    -------
    list
        ``[plant, controller]`` or ``[plant.discretize(dt), controller]``; for a numpy-only
        controller (:mod:`servokit.models.rational`) the plant's ZOH as numpy arrays too
        (:meth:`~servokit.models.ModalPlant.discretize_data`, the same matrices), so the
        loop never loads python-control.
    """
    dt = getattr(controller, "dt", None)
    if dt not in (None, 0, True) and dt:
        if isinstance(controller, RationalTF | StateSpaceData):
            return [plant.discretize_data(float(dt)), controller]
        return [plant.discretize(float(dt)), controller]
    return [plant, controller]


def _png(fig: Any) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


@dataclass
class FitSection:
    """A measured frequency response against the fitted plant.

    Parameters
    ----------
    freq_hz : array_like
        Measurement frequencies [Hz].
    measured : array_like of complex
        Measured response.
    plant : ModalPlant
        Fitted model.
    """

    freq_hz: np.ndarray
    measured: np.ndarray
    plant: ModalPlant
    title: str = "Fit over the measured frequency response"

    def __post_init__(self) -> None:
        self.freq_hz = np.asarray(self.freq_hz, dtype=float)
        self.measured = np.asarray(self.measured, dtype=complex)
        if self.freq_hz.shape != self.measured.shape or self.freq_hz.size < 2:
            raise ServokitValueError("FitSection: freq_hz and measured need one value each")
        self.model = self.plant.freqresp(self.freq_hz)
        self.rel_error = np.abs(self.model / self.measured - 1.0)

    def summary(self) -> list[tuple[str, str]]:
        """Headline numbers (label, value)."""
        return [
            ("points", f"{self.freq_hz.size}"),
            ("band [Hz]", f"{self.freq_hz.min():.4g} .. {self.freq_hz.max():.4g}"),
            ("median |model / measured - 1|", f"{100 * np.median(self.rel_error):.3g} %"),
            ("largest |model / measured - 1|", f"{100 * self.rel_error.max():.3g} %"),
            ("modes", f"{len(self.plant.modes)}"),
            ("delay [µs]", f"{self.plant.delay * 1e6:.4g}"),
        ]

    def table(self) -> tuple[list[str], list[list[str]]]:
        """The fitted modes."""
        rows = [
            [f"{m.freq_hz:.6g}", f"{m.damping:.4g}", f"{m.residue * self.plant.gain:.6g}"]
            for m in self.plant.modes
        ]
        return ["frequency [Hz]", "damping", "gain x residue"], rows

    def figure(self) -> bytes:
        """Bode overlay of data and model."""
        import matplotlib.pyplot as plt

        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
        for resp, style, label in ((self.measured, ".", "measured"), (self.model, "-", "model")):
            ax1.semilogx(self.freq_hz, 20 * np.log10(np.abs(resp)), style, ms=2, label=label)
            ax2.semilogx(self.freq_hz, np.degrees(np.unwrap(np.angle(resp))), style, ms=2)
        ax1.set_ylabel("Magnitude [dB]")
        ax2.set_ylabel("Phase [deg]")
        ax2.set_xlabel("Frequency [Hz]")
        ax1.legend()
        ax1.set_title(self.title)
        for ax in (ax1, ax2):
            ax.grid(True, which="both", alpha=0.3)
        return _png(fig)


@dataclass
class MarginsSection:
    """Stability margins of ``P_v C`` for every plant of a set, the worst marked.

    Parameters
    ----------
    plants : sequence of ModalPlant
        The plant set (nominal first, by convention).
    controller : control.LTI or RationalTF
        The feedback controller.
    """

    plants: Sequence[ModalPlant]
    controller: Any
    title: str = "Stability margins per plant"
    margins: list[Any] = field(init=False)

    def __post_init__(self) -> None:
        from servokit.feedback import stability_margins

        if not self.plants:
            raise ServokitValueError("MarginsSection: give at least one plant")
        self.margins = [stability_margins(loop_factors(p, self.controller)) for p in self.plants]

    @property
    def worst_gain_margin(self) -> int:
        """Index of the plant of least gain margin."""
        return int(np.argmin([abs(m.gain_margin_db) for m in self.margins]))

    @property
    def worst_phase_margin(self) -> int:
        """Index of the plant of least phase margin."""
        return int(np.argmin([m.phase_margin_deg for m in self.margins]))

    def summary(self) -> list[tuple[str, str]]:
        """Headline numbers (label, value)."""
        g, p = self.margins[self.worst_gain_margin], self.margins[self.worst_phase_margin]
        return [
            ("plants", f"{len(self.plants)}"),
            ("worst gain margin [dB]", f"{g.gain_margin_db:.4g} (plant {self.worst_gain_margin})"),
            (
                "worst phase margin [deg]",
                f"{p.phase_margin_deg:.4g} (plant {self.worst_phase_margin})",
            ),
        ]

    def table(self) -> tuple[list[str], list[list[str]]]:
        """One row per plant."""
        rows = []
        for i, (pl, m) in enumerate(zip(self.plants, self.margins, strict=True)):
            worst = i in (self.worst_gain_margin, self.worst_phase_margin)
            rows.append(
                [
                    f"{i}{' (worst)' if worst else ''}",
                    pl.name,
                    f"{m.gain_margin_db:.4g}",
                    f"{m.phase_margin_deg:.4g}",
                    f"{m.pm_freq_hz:.5g}",
                    f"{m.delay_margin_s * 1e6:.4g}",
                ]
            )
        head = ["plant", "name", "GM [dB]", "PM [deg]", "crossover [Hz]", "delay margin [µs]"]
        return head, rows

    def figure(self) -> bytes:
        """Gain margin against phase margin, one dot per plant."""
        import matplotlib.pyplot as plt

        gm = [m.gain_margin_db for m in self.margins]
        pm = [m.phase_margin_deg for m in self.margins]
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.plot(pm, gm, "o", ms=4, label="plants")
        for i, lab in ((self.worst_gain_margin, "worst GM"), (self.worst_phase_margin, "worst PM")):
            ax.plot(pm[i], gm[i], "s", mfc="none", ms=10, label=lab)
        ax.set_xlabel("Phase margin [deg]")
        ax.set_ylabel("Gain margin [dB]")
        ax.set_title(self.title)
        ax.grid(True, alpha=0.3)
        ax.legend()
        return _png(fig)


@dataclass
class SeekSection:
    """Seek times of a feedforward input over a plant set.

    Parameters
    ----------
    seek_times_s : array_like
        Seek time per plant [s].
    worst_s : float, optional
        Reported worst case [s] (e.g. a validated worst including plants found by a
        search); default the largest of ``seek_times_s``.
    guarantee_s : float, optional
        The design's guarantee on its design set [s].
    """

    seek_times_s: np.ndarray
    worst_s: float | None = None
    guarantee_s: float | None = None
    title: str = "Seek-time distribution"

    def __post_init__(self) -> None:
        self.seek_times_s = np.asarray(self.seek_times_s, dtype=float).ravel()
        if self.seek_times_s.size == 0:
            raise ServokitValueError("SeekSection: give at least one seek time")
        if self.worst_s is None:
            self.worst_s = float(self.seek_times_s.max())

    def summary(self) -> list[tuple[str, str]]:
        """Headline numbers (label, value)."""
        t = self.seek_times_s * 1e3
        rows = [
            ("plants", f"{t.size}"),
            ("worst seek time [ms]", f"{self.worst_s * 1e3:.6g}"),
            ("median [ms]", f"{np.median(t):.6g}"),
            ("99th percentile [ms]", f"{np.percentile(t, 99):.6g}"),
        ]
        if self.guarantee_s is not None:
            rows.append(("design-set guarantee [ms]", f"{self.guarantee_s * 1e3:.6g}"))
        return rows

    def table(self) -> None:
        """No table."""
        return None

    def figure(self) -> bytes:
        """Histogram with the worst case (and guarantee) marked."""
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 4))
        t = self.seek_times_s[np.isfinite(self.seek_times_s)] * 1e3
        ax.hist(t, bins=min(50, max(5, t.size // 20)), label=f"{t.size} plants")
        ax.axvline(self.worst_s * 1e3, color="C3", label="worst case")
        if self.guarantee_s is not None:
            ax.axvline(self.guarantee_s * 1e3, color="C2", ls="--", label="design guarantee")
        ax.set_xlabel("Seek time [ms]")
        ax.set_ylabel("Plants")
        ax.set_title(self.title)
        ax.legend()
        return _png(fig)


@dataclass
class SensitivitySection:
    """``|S(f)| = |1 / (1 + P_v C)|`` over a plant set, and its peak.

    Parameters
    ----------
    plants : sequence of ModalPlant
    controller : control.LTI or RationalTF
    freq_hz : array_like, optional
        Frequencies [Hz] (default: 1 Hz to Nyquist, or 1 Hz to 100 kHz if continuous).
    """

    plants: Sequence[ModalPlant]
    controller: Any
    freq_hz: np.ndarray | None = None
    title: str = "Sensitivity |S| per plant"

    def __post_init__(self) -> None:
        from servokit.feedback.margins import loop_response

        dt = getattr(self.controller, "dt", None)
        top = 0.5 / dt * 0.999 if dt else 1e5
        f = np.geomspace(1.0, top, 2000) if self.freq_hz is None else np.asarray(self.freq_hz)
        self.freq_hz = f
        self.magnitude = np.array(
            [
                np.abs(1.0 / (1.0 + loop_response(loop_factors(p, self.controller))[0](f)))
                for p in self.plants
            ]
        )

    def summary(self) -> list[tuple[str, str]]:
        """Headline numbers (label, value)."""
        peak = self.magnitude.max(axis=1)
        v = int(np.argmax(peak))
        f = self.freq_hz[int(np.argmax(self.magnitude[v]))]
        return [
            ("plants", f"{len(self.plants)}"),
            ("worst peak |S| [dB]", f"{20 * np.log10(peak[v]):.4g} at {f:.5g} Hz (plant {v})"),
        ]

    def table(self) -> None:
        """No table."""
        return None

    def figure(self) -> bytes:
        """|S| of every plant."""
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        for i, m in enumerate(self.magnitude):
            ax.semilogx(self.freq_hz, 20 * np.log10(m), lw=0.8, label="nominal" if i == 0 else None)
        ax.set_xlabel("Frequency [Hz]")
        ax.set_ylabel("|S| [dB]")
        ax.set_title(self.title)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        return _png(fig)


def design_report(
    path: str | Path,
    sections: Sequence[Any],
    *,
    title: str = "Design report",
    notes: Sequence[str] = (),
) -> Path:
    """Write a self-contained HTML design report (figures embedded).

    Parameters
    ----------
    path : str or Path
        The ``.html`` file to write.
    sections : sequence
        :class:`FitSection`, :class:`MarginsSection`, :class:`SeekSection`,
        :class:`SensitivitySection` (any object with ``title``, ``summary()``, ``table()``
        and ``figure()``), in page order.
    title : str
        Page title.
    notes : sequence of str
        Paragraphs shown under the title (what was designed, with which command).

    Returns
    -------
    Path
        The written file.
    """
    from servokit import __version__
    from servokit.report.html import environment, png_data_uri

    if not sections:
        raise ServokitValueError("design_report: give at least one section")
    items = []
    for s in sections:
        table = s.table()
        items.append(
            {
                "title": s.title,
                "summary": s.summary(),
                "table": table,
                "figure": png_data_uri(s.figure()),
            }
        )
    html = (
        environment()
        .get_template("design.html.j2")
        .render(title=title, notes=list(notes), sections=items, version=__version__)
    )
    path = Path(path)
    path.write_text(html, encoding="utf-8")
    return path
