"""
CSV tables with a header row: the station, stand and rotation inputs of the CLI.

Values are floats; a column is found by its header name, whatever its place.
A table is read row by row into float blocks, only the columns asked for,
so memory stays bounded (MAX_ROWS rows, MAX_COLUMNS columns, lines of at
most MAX_LINE_CHARS characters); anything that is not such a table, binary
garbage included, is a TableError with the reason and the line.
"""

import csv
import math

from inclino_ros.io.files import open_regular

import numpy as np

#: Most data rows of a table (an 80-minute stand at 1 kHz).
MAX_ROWS = 5_000_000
#: Most shots of a shot table (a fit holds ~4 kB per shot: 1e6 shots took 4 GB).  A
#: hand-held calibration takes 100-200 shots, a well's survey a few thousand stations.
MAX_SHOTS = 20_000
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


def _open_reader(path, read):
    """Return ``read(csv reader)`` of the CSV file ``path``; TableError if it is no table."""
    try:
        stream = open_regular(path, 'r', newline='', encoding='utf-8-sig')
    except OSError as err:
        raise TableError(f'cannot read {path}: {err}') from None
    try:
        with stream:
            return read(csv.reader(_lines(stream, path)))
    except (csv.Error, UnicodeDecodeError, OSError) as err:
        raise TableError(f'{path} is not a CSV table ({err})') from None


def _header(reader, path):
    """Return the stripped header names of an open csv reader; TableError if unusable."""
    header = next(reader, None)
    if not header:
        raise TableError(f'{path} is empty')
    header = [name.strip() for name in header]
    if len(header) > MAX_COLUMNS:
        raise TableError(f'{path} has {len(header)} columns, at most {MAX_COLUMNS} are read')
    repeated = sorted({name for name in header if header.count(name) > 1})
    if repeated:
        raise TableError(f'{path} names the column(s) {", ".join(repeated)} more than once')
    return header


def _rows(reader, path, header, max_rows=MAX_ROWS):
    """
    Yield the data rows of an open csv reader: at most ``max_rows``, len(header) cells each.

    A row with a cell too many or too few would shift every later column (a
    value read under another's name), a blank line would be a row of no
    values: either refuses the table, naming the line.
    """
    for count, row in enumerate(reader, start=1):
        if not row:
            raise TableError(f'{path} line {reader.line_num} is blank: every row needs '
                             f'{len(header)} values (remove the line)')
        if len(row) != len(header):
            raise TableError(f'{path} line {reader.line_num}: every row needs {len(header)} '
                             f'values ({", ".join(header)}), this one has {len(row)}: '
                             'its values would be read under the wrong columns')
        if count > max_rows:
            raise TableError(f'{path} has more than {max_rows} rows, the most this command '
                             'reads')
        yield row


def read_csv(path, required, optional=(), text=(), max_rows=MAX_ROWS):
    """
    Return ``{column: float array}`` of a CSV file with a header row.

    ``required`` columns must be present, ``optional`` ones are returned when
    present; ``text`` columns (optional) come back as lists of stripped
    strings; other columns are ignored (but every row must have a value for
    each).  At most ``max_rows`` data rows (a command passes what it needs,
    memory grows with it).  Raises TableError otherwise.
    """
    return _open_reader(path, lambda reader: _read_table(reader, path, required, optional,
                                                         text, max_rows))


def header_of(path):
    """Return the stripped column names of a CSV file's header row; TableError if unusable."""
    return _open_reader(path, lambda reader: _header(reader, path))


def read_rows(path, max_rows=MAX_ROWS):
    """
    Return (header names, data rows as lists of strings) of a CSV file.

    The rows are checked as ``read_csv``'s (len(header) cells, no blank
    line, at most ``max_rows``); TableError otherwise or if there is none.
    """
    def read(reader):
        header = _header(reader, path)
        rows = list(_rows(reader, path, header, max_rows))
        if not rows:
            raise TableError(f'{path} has no data rows')
        return header, rows
    return _open_reader(path, read)


def number_column(rows, header, name):
    """Return column ``name`` as floats, NaN where a cell is not a number."""
    index = header.index(name)

    def number(text):
        try:
            return float(text)
        except ValueError:
            return math.nan
    return np.array([number(row[index]) if index < len(row) else math.nan for row in rows])


def count_column(path, rows, header, name):
    """Return column ``name`` as whole counts >= 1 (1 without the column); TableError if not."""
    if name not in header:
        return 1
    counts = number_column(rows, header, name)
    bad = np.flatnonzero(~((counts >= 1) & (np.mod(counts, 1.0) == 0.0)))
    if bad.size:
        row, index = rows[bad[0]], header.index(name)
        cell = row[index] if index < len(row) else ''
        raise TableError(f'{path}: column {name} must be a whole count >= 1 '
                         f'(row {bad[0] + 1} has {cell!r})')
    return counts


def _read_table(reader, path, required, optional, text, max_rows):
    """Return the columns of an open csv reader (see ``read_csv``)."""
    header = _header(reader, path)
    missing = [name for name in required if name not in header]
    if missing:
        raise TableError(f'{path} lacks the column(s) {", ".join(missing)}; '
                         f'it has {", ".join(header)}')
    names = [name for name in (*required, *optional) if name in header and name not in text]
    used = [header.index(name) for name in names]
    words = {name: [] for name in text if name in header}
    blocks, block, filled = [], np.empty((_BLOCK_ROWS, len(used))), 0
    for row in _rows(reader, path, header, max_rows):
        try:
            block[filled] = [float(row[i]) for i in used]
        except ValueError as err:
            raise TableError(f'{path} line {reader.line_num}: {err}') from None
        for name, values in words.items():
            values.append(row[header.index(name)].strip())
        filled += 1
        if filled == _BLOCK_ROWS:
            blocks.append(block)
            block, filled = np.empty_like(block), 0
    blocks.append(block[:filled])
    values = np.concatenate(blocks)
    if values.shape[0] == 0:
        raise TableError(f'{path} has no data rows')
    columns = {name: values[:, k] for k, name in enumerate(names)}
    columns.update(words)
    return columns


def read_shots(path, accel_columns=('ax', 'ay', 'az'), field_columns=('bx', 'by', 'bz'),
               group_column='roll_group'):
    """
    Return the still shots of a CSV: (accel (N, 3), field (N, 3), group labels or None, T or None).

    One row per shot; rows with the same non-empty ``group_column`` value
    are one roll group (labels 0, 1, ... in order of appearance, -1 for none);
    ``temperature_c`` optional.  TableError for a row with a non-finite value
    (named), more than MAX_SHOTS rows, or a table ``read_csv`` refuses.
    """
    table = read_csv(path, tuple(accel_columns) + tuple(field_columns),
                     optional=('temperature_c',), text=(group_column,), max_rows=MAX_SHOTS)
    accel = np.column_stack([table[name] for name in accel_columns])
    field = np.column_stack([table[name] for name in field_columns])
    bad = np.flatnonzero(~(np.isfinite(accel).all(axis=1) & np.isfinite(field).all(axis=1)))
    if bad.size:
        raise TableError(f'non-finite values in row(s) {(bad + 1).tolist()} of {path} (data '
                         'rows, counted from 1 after the header): drop or retake those shots')
    groups = table.get(group_column)
    labels = None
    if groups is not None and any(groups):
        names = list(dict.fromkeys(name for name in groups if name))
        labels = np.array([names.index(name) if name else -1 for name in groups])
    return accel, field, labels, table.get('temperature_c')


def _cell(value):
    """Return one CSV cell: text as it is, 1/0 for flags, integers whole, repr for floats."""
    if isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        return '1' if value else '0'
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return repr(float(value))


def _cells(values):
    """Return a column's cells (``_cell``), whole numpy columns converted at once."""
    array = np.asarray(values)
    if array.dtype == bool:
        return ['1' if v else '0' for v in array.tolist()]
    if array.dtype.kind in 'iu':
        return [str(v) for v in array.tolist()]
    if array.dtype.kind == 'f':
        return [repr(v) for v in array.tolist()]
    return [_cell(v) for v in values]


def write_csv(path, columns, mode='x'):
    """
    Write ``columns`` as a CSV with a header row: the one table writer of the package.

    ``columns``: ``{name: values}`` or ``[(name, values)]`` (names may then
    repeat), all of one length.  Cells: text as it is, flags as 1/0,
    integers whole, floats in full precision (``repr``: read back bit for bit;
    NaN as ``nan``).  ``mode`` 'x' (the default) never overwrites a file.
    """
    items = list(columns.items() if isinstance(columns, dict) else columns)
    cells = [_cells(values) for _, values in items]
    with open(path, mode, newline='') as stream:
        writer = csv.writer(stream, lineterminator='\n')   # not the module's CRLF
        writer.writerow([name for name, _ in items])
        writer.writerows(zip(*cells))
