"""The figure of ``nudge plot-population``: simulated participants' fitted diagonals beside real people's.

Two panels, one per stream format (the pilots' fixed 10 Hz stream; the sibling study's
event-driven stream). In each, per intended label, every simulated participant's fitted
``p(phi_m = phi_i | phi_i)`` is a dot (spread sideways so they do not hide each other), and the
real people's values are drawn beside them: the sibling study's span as a gray bar, the pilots as
black diamonds (in the event-driven panel: their own blows as that device would count them).
Inputs are :func:`nudgecli.sim.real_population.simulated_diagonals` and
:data:`~nudgecli.sim.real_population.PILOT_DIAGONALS` / ``PILOT_EVENT_DIAGONALS`` /
``SIBLING_DIAGONAL_SPANS``.

Below them, given the participants' drawn timing habits
(:func:`nudgecli.sim.real_population.simulated_habits`), a habits panel: per habit every simulated
person's value (dots) beside the range of the ten real people's medians of HABITS.md (gray bars;
the packaged reference ``ciaa-people``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from nudgecli.model.interface import LABELS
from nudgecli.reference import people_ranges
from nudgecli.report.figures.common import axes_or_new
from nudgecli.report.figures.output import save_figure
from nudgecli.report.style import FULL_WIDTH_IN, OKABE_ITO, figure_style
from nudgecli.sim.real_population import PILOT_DIAGONALS, PILOT_EVENT_DIAGONALS, SIBLING_DIAGONAL_SPANS

#: File stem of the figure.
FIGURE_STEM = "population"
#: Panel titles per stream format.
STREAM_TITLES = {
    "fixed_rate": "fixed 10 Hz stream (pilots' protocol)",
    "event_driven": "event-driven stream (sibling study's protocol)",
}


def population_panel(simulated: pd.DataFrame, stream: str, *, ax: Axes | None = None) -> Axes:
    """One stream format: per intended label the simulated participants' fitted diagonals (dots,
    spread sideways by rank) and the real people's beside them (the pilots as diamonds; for the
    event-driven stream also the sibling study's span as a bar).

    Parameters
    ----------
    simulated
        Columns ``participant``, ``stream``, ``label``, ``diagonal``.
    stream
        A key of :data:`STREAM_TITLES`.
    ax
        Axes to draw on; default a new figure's.
    """
    ax = axes_or_new(ax, (FULL_WIDTH_IN / 2, 2.9))
    own = simulated[simulated["stream"] == stream]
    for k, label in enumerate(LABELS):
        values = own.loc[own["label"] == label, "diagonal"].to_numpy(dtype=float)
        # a deterministic sideways spread: by rank, so equal values do not overlap
        rank = np.argsort(np.argsort(values, kind="stable"))
        offsets = (rank / max(len(values) - 1, 1) - 0.5) * 0.15
        ax.scatter(k - 0.12 + offsets, values, s=7, color=OKABE_ITO["blue"], alpha=0.75,
                   linewidths=0, label="simulated participants" if k == 0 else None)
        pilot_values = PILOT_DIAGONALS if stream == "fixed_rate" else PILOT_EVENT_DIAGONALS
        if stream == "event_driven":
            low, high = SIBLING_DIAGONAL_SPANS[label]
            ax.bar(k + 0.22, high - low, bottom=low, width=0.14, color="#BDBDBD", edgecolor="#4D4D4D",
                   linewidth=0.6, label="sibling study, 9 people (span)" if k == 0 else None)
        pilots = [values_of[label] for values_of in pilot_values.values()]
        ax.scatter(np.full(len(pilots), k + 0.22), pilots, s=16, marker="D", color=OKABE_ITO["black"],
                   zorder=3, label=(("pilots (nudge fit of their logs)" if stream == "fixed_rate"
                                     else "pilots' blows, counted as this device would") if k == 0 else None))
    ax.set_xticks(range(len(LABELS)), [label.replace(" ", "\n") for label in LABELS])
    ax.set_xlim(-0.6, len(LABELS) - 0.4)
    ax.set_ylim(-0.02, 1.02)
    ax.set_title(STREAM_TITLES[stream], loc="left")
    ax.legend(loc="lower left")
    return ax


#: The habits panel's habits and their tick labels.
HABIT_TITLES = {
    "first_command_latency": "first\ncommand",
    "reaction_stop_to_switch": "stop at waypoint\n-> switch",
    "reaction_switch_to_motion": "switch\n-> moves",
    "hard_band_per_excursion": "hard band per\nexcursion",
    "hold_on_per_stop": "hold-on\nper stop",
}


def habits_panel(habits: pd.DataFrame, *, ax: Axes | None = None) -> Axes:
    """Per habit the simulated people's values (dots, spread sideways by rank) beside the range of
    the ten real people's medians (HABITS.md; a gray bar).

    Parameters
    ----------
    habits
        Columns ``participant``, ``habit``, ``value`` (seconds).
    ax
        Axes to draw on; default a new figure's.
    """
    ax = axes_or_new(ax, (FULL_WIDTH_IN, 2.7))
    real = people_ranges("ciaa-people")
    for k, habit in enumerate(HABIT_TITLES):
        values = habits.loc[habits["habit"] == habit, "value"].to_numpy(dtype=float)
        rank = np.argsort(np.argsort(values, kind="stable"))
        offsets = (rank / max(len(values) - 1, 1) - 0.5) * 0.25
        ax.scatter(k - 0.15 + offsets, values, s=7, color=OKABE_ITO["blue"], alpha=0.75, linewidths=0,
                   label="simulated participants (drawn parameter + mechanical offset)" if k == 0 else None)
        low, high = real[habit]
        ax.bar(k + 0.22, high - low, bottom=low, width=0.14, color="#BDBDBD", edgecolor="#4D4D4D",
               linewidth=0.6, label="10 real users, range of their medians (HABITS.md)" if k == 0 else None)
    ax.set_xticks(range(len(HABIT_TITLES)), list(HABIT_TITLES.values()))
    ax.set_xlim(-0.6, len(HABIT_TITLES) - 0.4)
    ax.set_ylim(bottom=0.0)
    ax.set_ylabel("seconds")
    ax.set_title("operating habits (sibling study's task, no assistance)", loc="left")
    ax.legend(loc="upper right")
    return ax


def build_population_figure(simulated: pd.DataFrame, title: str = "",
                            habits: pd.DataFrame | None = None) -> Figure:
    """The figure (see the module docstring): :func:`population_panel` per stream format.

    Parameters
    ----------
    simulated
        Columns ``participant``, ``stream``, ``label``, ``diagonal``.
    title
        A suptitle (e.g. the experiment and the number of participants).
    habits
        Columns ``participant``, ``habit``, ``value``: adds :func:`habits_panel` below.
    """
    with figure_style():
        fig = Figure(figsize=(FULL_WIDTH_IN, 2.9 if habits is None else 5.8), layout="constrained")
        FigureCanvasAgg(fig)
        if habits is None:
            axes = fig.subplots(1, 2, sharey=True)
        else:
            mosaic = fig.subplot_mosaic([["fixed_rate", "event_driven"], ["habits", "habits"]])
            axes = [mosaic["fixed_rate"], mosaic["event_driven"]]
            axes[1].sharey(axes[0])
            habits_panel(habits, ax=mosaic["habits"])
        for ax, stream in zip(axes, STREAM_TITLES, strict=True):
            population_panel(simulated, stream, ax=ax)
        axes[0].set_ylabel(r"fitted $p(\phi_m = \phi_i \mid \phi_i)$")
        if title:
            fig.suptitle(title)
    return fig


def plot_population(simulated: pd.DataFrame, out_dir: str | os.PathLike[str],
                    formats: Sequence[str] = ("png", "pdf"), title: str = "",
                    habits: pd.DataFrame | None = None) -> list[Path]:
    """Draw :func:`build_population_figure` and write ``population.<fmt>`` into ``out_dir``."""
    return save_figure(build_population_figure(simulated, title, habits), out_dir, FIGURE_STEM, formats)
