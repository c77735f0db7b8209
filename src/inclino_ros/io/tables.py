"""
CSV tables with a header row: the station, stand and rotation inputs of the CLI.

Values are floats; a column is found by its header name, whatever its place.
"""

import csv

import numpy as np


class TableError(ValueError):
    """A CSV file that cannot be used, with the reason."""


def read_csv(path, required, optional=(), text=()):
    """
    Return ``{column: float array}`` of a CSV file with a header row.

    ``required`` columns must be present, ``optional`` ones are returned when
    present; ``text`` columns (optional) come back as lists of stripped
    strings; other columns are ignored.  Raises TableError otherwise.
    """
    header, rows = read_rows(path)
    missing = [name for name in required if name not in header]
    if missing:
        raise TableError(f'{path} lacks the column(s) {", ".join(missing)}; '
                         f'it has {", ".join(header)}')
    if any(len(row) != len(header) for row in rows):
        raise TableError(f'{path}: every row needs {len(header)} values')
    numeric = [name for name in (*required, *optional) if name in header and name not in text]
    try:
        values = np.array([[row[header.index(name)] for name in numeric] for row in rows],
                          dtype=float).reshape(len(rows), len(numeric))
    except ValueError as err:
        raise TableError(f'{path}: every row needs {len(header)} numbers ({err})') from None
    columns = {name: values[:, k] for k, name in enumerate(numeric)}
    columns.update({name: [row[header.index(name)].strip() for row in rows]
                    for name in text if name in header})
    return columns


def read_rows(path):
    """Return (header names, data rows as lists of strings) of a CSV file; TableError if empty."""
    try:
        with open(path, newline='') as stream:
            rows = list(csv.reader(stream))
    except OSError as err:
        raise TableError(f'cannot read {path}: {err}') from None
    if not rows:
        raise TableError(f'{path} is empty')
    header = [name.strip() for name in rows[0]]
    if len(rows) == 1:
        raise TableError(f'{path} has no data rows')
    return header, rows[1:]
