"""
CSV tables with a header row: the station, stand and rotation inputs of the CLI.

Values are floats; a column is found by its header name, whatever its place.
"""

import csv

import numpy as np


class TableError(ValueError):
    """A CSV file that cannot be used, with the reason."""


def read_csv(path, required, optional=()):
    """
    Return ``{column: float array}`` of a CSV file with a header row.

    ``required`` columns must be present, ``optional`` ones are returned when
    present; other columns are ignored.  Raises TableError otherwise.
    """
    try:
        with open(path, newline='') as stream:
            rows = list(csv.reader(stream))
    except OSError as err:
        raise TableError(f'cannot read {path}: {err}') from None
    if not rows:
        raise TableError(f'{path} is empty')
    header = [name.strip() for name in rows[0]]
    missing = [name for name in required if name not in header]
    if missing:
        raise TableError(f'{path} lacks the column(s) {", ".join(missing)}; '
                         f'it has {", ".join(header)}')
    try:
        values = np.array(rows[1:], dtype=float).reshape(len(rows) - 1, len(header))
    except ValueError as err:
        raise TableError(f'{path}: every row needs {len(header)} numbers ({err})') from None
    if values.shape[0] == 0:
        raise TableError(f'{path} has no data rows')
    return {name: values[:, header.index(name)]
            for name in (*required, *optional) if name in header}
