"""
CSV tables with a header row: the station, stand and rotation inputs of the CLI.

Values are floats; a column is found by its header name, whatever its place.
A table is read row by row into float blocks, only the columns asked for,
so memory stays bounded (MAX_ROWS rows, MAX_COLUMNS columns, lines of at
most MAX_LINE_CHARS characters); anything that is not such a table, binary
garbage included, is a TableError with the reason and the line.
"""

import csv

import numpy as np

#: Most data rows of a table (an 80-minute stand at 1 kHz).
MAX_ROWS = 5_000_000
#: Most columns of a table.
MAX_COLUMNS = 1000
#: Longest line of a table [characters].
MAX_LINE_CHARS = 100_000
#: Rows converted per block.
_BLOCK_ROWS = 65536


class TableError(ValueError):
    """A CSV file that cannot be used, with the reason."""


def _lines(stream, path):
    """Yield the lines of ``stream``, none read whole beyond MAX_LINE_CHARS."""
    while True:
        line = stream.readline(MAX_LINE_CHARS + 1)
        if not line:
            return
        if len(line) > MAX_LINE_CHARS:
            raise TableError(f'{path} has a line longer than {MAX_LINE_CHARS} characters: '
                             'not a table of numbers')
        yield line


def read_csv(path, required, optional=()):
    """
    Return ``{column: float array}`` of a CSV file with a header row.

    ``required`` columns must be present, ``optional`` ones are returned when
    present; other columns are ignored (but every row must have a value for
    each).  Raises TableError otherwise.
    """
    try:
        stream = open(path, newline='', encoding='utf-8-sig')
    except OSError as err:
        raise TableError(f'cannot read {path}: {err}') from None
    try:
        with stream:
            reader = csv.reader(_lines(stream, path))
            return _read_table(reader, path, required, optional)
    except (csv.Error, UnicodeDecodeError, OSError) as err:
        raise TableError(f'{path} is not a CSV table ({err})') from None


def _read_table(reader, path, required, optional):
    """Return the columns of an open csv reader (see ``read_csv``)."""
    header = next(reader, None)
    if not header:
        raise TableError(f'{path} is empty')
    header = [name.strip() for name in header]
    if len(header) > MAX_COLUMNS:
        raise TableError(f'{path} has {len(header)} columns, at most {MAX_COLUMNS} are read')
    repeated = sorted({name for name in header if header.count(name) > 1})
    if repeated:
        raise TableError(f'{path} names the column(s) {", ".join(repeated)} more than once')
    missing = [name for name in required if name not in header]
    if missing:
        raise TableError(f'{path} lacks the column(s) {", ".join(missing)}; '
                         f'it has {", ".join(header)}')
    names = [name for name in (*required, *optional) if name in header]
    used = [header.index(name) for name in names]
    blocks, block, filled, rows = [], np.empty((_BLOCK_ROWS, len(used))), 0, 0
    for row in reader:
        if len(row) != len(header):
            raise TableError(f'{path} line {reader.line_num}: every row needs {len(header)} '
                             f'numbers, this one has {len(row)}')
        try:
            block[filled] = [float(row[i]) for i in used]
        except ValueError as err:
            raise TableError(f'{path} line {reader.line_num}: {err}') from None
        filled += 1
        rows += 1
        if rows > MAX_ROWS:
            raise TableError(f'{path} has more than {MAX_ROWS} rows')
        if filled == _BLOCK_ROWS:
            blocks.append(block)
            block, filled = np.empty_like(block), 0
    blocks.append(block[:filled])
    values = np.concatenate(blocks)
    if values.shape[0] == 0:
        raise TableError(f'{path} has no data rows')
    return {name: values[:, k] for k, name in enumerate(names)}
