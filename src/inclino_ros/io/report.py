"""
The reports of a fit: the residual table of its text report and its calibration certificate.

One place renders both for every fit command (``cli.fitting.run_fit``).
A fit states its residuals as ``Residual`` rows, one per position,
temperature, shot or sector of a rotation: what was measured there, the
noise it is judged against (the fit's own stated noise, same unit) and
whether it was used, down-weighted or refused.  ``residual_lines`` writes
them into the text report, ``certificate_html`` into the certificate.

The certificate is one self-contained HTML page a test lab files with the
tool: sensor id, date, the temperature range of the file's stages, every
stage of the calibration file with every value it holds (the uncertainties
among them: a key with ``std``, ``sigma``, ``rmse`` or ``noise`` in its
name is marked as one), the residual table, the refused and down-weighted
rows and the report figures embedded as base64 PNG.  Every number of the
file is in an element ``data-field="STAGE.KEY"`` whose ``data-value`` is the
number as JSON (full precision): a reader (or a test) compares the page with
the calibration file without parsing the printed text.
"""

import base64
from dataclasses import dataclass
import html
import json
import math

import numpy as np

#: What a row of the residual table can be.
USED, DOWN_WEIGHTED, REFUSED = 'used', 'down-weighted', 'refused'
#: Key fragments that name an uncertainty in a calibration file section.
UNCERTAINTY_KEYS = ('std', 'sigma', 'rmse', 'noise', 'uncertainty')
#: Keys of a temperature stage's fitted range [C].
FITTED_RANGE_KEYS = ('t_min_c', 't_max_c')


@dataclass(frozen=True)
class Residual:
    """
    One row of a fit's residual table.

    ``residual`` and ``noise`` in ``unit``: the residual measured at this
    ``label`` (a position, temperature, shot or sector) and the noise the
    fit states for it (NaN: none stated); ``status`` USED, DOWN_WEIGHTED or
    REFUSED, ``note`` why (empty when used as it is).
    """

    label: str
    residual: float
    noise: float
    unit: str
    status: str = USED
    note: str = ''

    @property
    def ratio(self):
        """Return |residual| / noise (NaN when no noise is stated)."""
        if not (math.isfinite(self.noise) and self.noise > 0):
            return float('nan')
        return abs(self.residual) / self.noise


def _shown(value, fmt):
    """Return a number as printed, 'not stated' for NaN."""
    return format(value, fmt) if math.isfinite(value) else 'not stated'


def residual_lines(rows, title='residuals'):
    """Return the text report's lines of ``rows``: one per row, then what was not used."""
    if not rows:
        return [f"{title}: none in this fit's results"]
    width = max(len(row.label) for row in rows)
    lines = [f'{title} (residual against the stated noise; x noise = |residual| / noise):']
    for row in rows:
        noise = (f'noise {row.noise:8.4f} {row.unit}  x noise {row.ratio:6.2f}'
                 if math.isfinite(row.noise) else 'noise not stated')
        lines.append(f'  {row.label:<{width}}  {row.residual:+10.4f} {row.unit}  {noise}  '
                     f'{row.status}'
                     + (f' ({row.note})' if row.note else ''))
    left = [row for row in rows if row.status != USED]
    lines.append('down-weighted or refused: ' + (
        ', '.join(f'{row.label} ({row.status})' for row in left) if left else 'none'))
    return lines


def png_data_uri(path):
    """Return the PNG file ``path`` as a data: URI (base64), to embed in a page."""
    with open(path, 'rb') as stream:
        return 'data:image/png;base64,' + base64.b64encode(stream.read()).decode('ascii')


def _is_uncertainty(key):
    """Return whether a calibration file key names an uncertainty."""
    return any(part in key.lower() for part in UNCERTAINTY_KEYS)


def _number(value):
    """Return a number's text as the page prints it."""
    if isinstance(value, bool) or value is None:
        return str(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f'{value:.6g}' if math.isfinite(value) else 'NaN'
    return str(value)


def _value_cell(field, value):
    """Return a table cell holding ``value`` (number, list, text) with its data attributes."""
    shown = _value_text(value)
    return (f'<td data-field="{html.escape(field)}" '
            f'data-value="{html.escape(json.dumps(value), quote=True)}">'
            f'{html.escape(shown)}</td>')


def _value_text(value):
    """Return a value (a nested list too) as printed text."""
    if isinstance(value, (list, tuple)):
        return '[' + ', '.join(_value_text(v) for v in value) + ']'
    if isinstance(value, str):
        return value
    return _number(value)


def _stage_rows(name, section):
    """Return the HTML rows of one stage: one per key, uncertainties marked."""
    if not isinstance(section, dict):
        return [f'<tr><th>{html.escape(name)}</th>{_value_cell(name, section)}<td></td></tr>']
    rows = []
    for key, value in section.items():
        if isinstance(value, dict):
            rows += _stage_rows(f'{name}.{key}', value)
            continue
        kind = 'uncertainty' if _is_uncertainty(key) else ''
        rows.append(f'<tr class="{kind}"><th>{html.escape(key)}</th>'
                    f'{_value_cell(f"{name}.{key}", value)}<td>{kind}</td></tr>')
    return rows


def temperature_range_c(doc):
    """Return (lowest, highest) temperature [C] a calibration file's stages name, or None."""
    found = []

    def walk(node):
        if isinstance(node, dict):
            for key, value in node.items():
                if key.endswith('_c') and ('temperature' in key or key in FITTED_RANGE_KEYS):
                    found.extend(v for v in np.ravel(np.asarray(value, dtype=object))
                                 if isinstance(v, (int, float)) and not isinstance(v, bool)
                                 and math.isfinite(v))
                else:
                    walk(value)
    walk(doc)
    return (min(found), max(found)) if found else None


def _residual_table(rows):
    """Return the HTML table of the residual rows."""
    if not rows:
        return '<p id="no-residuals">No per-position residuals in this fit\'s results.</p>'
    body = []
    for i, row in enumerate(rows):
        body.append(
            f'<tr class="{row.status.replace(" ", "-")}" data-row="{i}">'
            f'<td data-col="label">{html.escape(row.label)}</td>'
            f'<td data-col="residual" data-value="{row.residual!r}">{row.residual:+.4f}</td>'
            f'<td data-col="noise" data-value="{row.noise!r}">{_shown(row.noise, ".4f")}</td>'
            f'<td>{html.escape(row.unit)}</td>'
            f'<td data-col="ratio">{_shown(row.ratio, ".2f")}</td>'
            f'<td data-col="status">{html.escape(row.status)}</td>'
            f'<td>{html.escape(row.note)}</td></tr>')
    return ('<table id="residuals"><tr><th>position / temperature / shot</th><th>residual</th>'
            '<th>stated noise (1 sigma)</th><th>unit</th><th>|residual| / noise</th>'
            '<th>status</th><th>why</th></tr>' + ''.join(body) + '</table>')


STYLE = """
body { font-family: sans-serif; margin: 2em; max-width: 70em; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.15em; border-bottom: 1px solid #999; }
table { border-collapse: collapse; margin: 0.5em 0; }
td, th { border: 1px solid #bbb; padding: 0.2em 0.6em; text-align: left;
  font-variant-numeric: tabular-nums; }
tr.uncertainty td, tr.uncertainty th { background: #eef5ff; }
tr.refused td { background: #fdd; } tr.down-weighted td { background: #ffe9c0; }
img { max-width: 100%; border: 1px solid #ccc; }
pre { background: #f6f6f6; padding: 0.6em; font-size: 0.85em; }
"""


def certificate_html(command, calibration_path, doc, rows, figures, report_lines, date_iso):
    """
    Return the calibration certificate of one fit, a self-contained HTML page.

    ``doc`` is the calibration file written (its JSON document), ``rows``
    the fit's ``Residual`` rows, ``figures`` (caption, PNG path) pairs
    embedded as base64, ``report_lines`` the text report, ``date_iso``
    when the certificate was made (UTC).
    """
    sensor = doc.get('sensor_id') or 'not named'
    span = temperature_range_c(doc)
    span_text = 'not recorded' if span is None else f'{span[0]:.2f} .. {span[1]:.2f} C'
    scalars = [_stage_rows(name, value)[0] for name, value in doc.items()
               if not isinstance(value, dict) and name != 'sensor_id']
    stages = ['<h3>file</h3><table class="stage"><tr><th>key</th><th>value</th><th></th></tr>'
              + ''.join(scalars) + '</table>'] if scalars else []
    for name, section in doc.items():
        if isinstance(section, dict):
            stages.append(f'<h3>{html.escape(name)}</h3><table class="stage" data-stage='
                          f'"{html.escape(name)}"><tr><th>key</th><th>value</th><th></th></tr>'
                          + ''.join(_stage_rows(name, section)) + '</table>')
    left = [row for row in rows if row.status != USED]
    refused = ('<ul id="not-used">' + ''.join(
        f'<li>{html.escape(row.label)}: {html.escape(row.status)}'
        + (f' ({html.escape(row.note)})' if row.note else '') + '</li>' for row in left)
        + '</ul>') if left else '<p id="not-used">None: every row was used at full weight.</p>'
    images = ''.join(
        f'<figure><img alt="{html.escape(caption)}" src="{png_data_uri(path)}">'
        f'<figcaption>{html.escape(caption)}</figcaption></figure>' for caption, path in figures)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>Calibration certificate: {html.escape(sensor)} ({html.escape(command)})</title>
<style>{STYLE}</style></head><body>
<h1>Calibration certificate: inclino {html.escape(command)}</h1>
<table id="summary">
<tr><th>sensor id</th><td id="sensor-id">{html.escape(sensor)}</td></tr>
<tr><th>date (UTC)</th><td id="date">{html.escape(date_iso)}</td></tr>
<tr><th>calibration file</th><td id="calibration-file">{html.escape(calibration_path)}</td></tr>
<tr><th>temperature range of the stages</th><td id="temperature-range"
 data-value="{html.escape(json.dumps(span), quote=True)}">{span_text}</td></tr>
</table>
<h2>Residuals against the stated noise</h2>
{_residual_table(rows)}
<h2>Down-weighted or refused</h2>
{refused}
<h2>Figures</h2>
{images or '<p>No figure.</p>'}
<h2>Every stage of the calibration file</h2>
<p>Shaded rows are uncertainties (1 sigma unless the key says otherwise).</p>
{''.join(stages)}
<h2>Report of the fit</h2>
<pre id="report">{html.escape(chr(10).join(report_lines))}</pre>
</body></html>
"""
