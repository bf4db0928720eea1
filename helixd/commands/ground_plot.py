"""The ground profile as a figure (``helixd ground --plot``): in a module of its own so that
the command imports matplotlib only when it draws (every command starts without it)."""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from helixd.commands.ground import GroundReport
from helixd.control.ground_fit import AXES


def plot_report(rep: GroundReport, path: Path) -> None:
    """The fractions per medium and mode, with their uncertainty, as a bar chart (matplotlib's
    object API and Agg canvas, as :mod:`helixd.recorder.plots`)."""
    fig = Figure(figsize=(8.0, 4.0))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    labels: list[str] = []
    x0 = 0
    for row in rep.rows:
        for k, axis in enumerate(AXES):
            f = row.view.fractions[axis]
            if f is None:
                continue
            err = row.view.sigmas[axis] or 0.0
            ax.bar(x0 + 0.27 * (k - 1), f, 0.25, yerr=err, color=f"C{k}", capsize=3)
        labels.append(f"{row.medium.value}\n{row.mode.value}")
        x0 += 1
    ax.set_xticks(range(len(labels)), labels)
    ax.set_ylabel("delivered fraction of the no-slip motion")
    ax.set_ylim(0.0, 1.2)
    ax.legend([Rectangle((0, 0), 1, 1, color=f"C{k}") for k in range(3)], list(AXES))
    ax.set_title(f"ground profile: {rep.source}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


__all__ = ["plot_report"]
