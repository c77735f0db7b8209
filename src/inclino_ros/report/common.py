"""What every fit report uses: stacked figure panels (matplotlib, Agg), matrix text, Fitted."""

from dataclasses import dataclass


def new_figure(rows, title):
    """Return (pyplot, figure, axes) of ``rows`` stacked panels (matplotlib, Agg)."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot

    fig, axes = pyplot.subplots(rows, 1, figsize=(9, 4 * rows))
    fig.suptitle(title)
    return pyplot, fig, axes


def finish_figure(pyplot, fig, axes, path):
    """Grid and legend on every panel, then write the figure to ``path``."""
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize='small')
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    pyplot.close(fig)


def matrix_lines(name, matrix, fmt):
    """Return a 3x3 matrix as indented text lines under ``name``."""
    return [f'{name}:'] + ['  ' + ' '.join(format(v, fmt) for v in row) for row in matrix]


@dataclass(frozen=True)
class Fitted:
    """
    What a fit returns to the command that ran it: the model it saved and its residual rows.

    ``model`` the ``CalibrationModel`` written; ``residuals`` the fit's
    ``io.report.Residual`` rows (its text report's residual table), which
    its calibration certificate shows (``io.report.certificate_html``).
    """

    model: object
    residuals: tuple = ()
