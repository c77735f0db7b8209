"""
Files written whole or not at all, never over an input or silently over another file.

Every file and bag the package writes goes through ``Outputs``: each output is
written, under its own name, into a temporary folder beside it
(``.NAME-PID-<random>.tmp/NAME``) and renamed into place only when the command
completed; on any failure, Ctrl-C included, the temporaries are removed and
what existed stays as it was.  An
output that exists already is refused unless ``force`` is given, and an
output that is one of the command's inputs (the same file, found by device
and inode, so a link or another spelling of the name is caught too) is
refused even then.  Temporaries a killed process left behind (its PID no
longer runs, or an older name without a PID) are removed at the next write of
the same output.

JSON documents are read with ``loads_strict``: a key that appears twice in
an object is an error, not "the last one wins".
"""

import json
import os
import re
import secrets
import shutil


#: Largest JSON file ``read_json`` reads: calibration and station files are kilobytes.
MAX_JSON_BYTES = 16 * 1024 * 1024


class OutputError(Exception):
    """An output that must not be written: it exists already, or it is an input."""


#: Outputs of this process being written now: their temporaries are not stale.
_IN_FLIGHT = set()


def temporary_path(final):
    """Return a new temporary name beside ``final`` (the file is not created)."""
    folder, name = os.path.split(os.path.abspath(final))
    return os.path.join(folder, f'.{name}-{os.getpid()}-{secrets.token_hex(4)}.tmp')


def _temporary_pattern(name):
    """Return the regex of the temporaries of ``name``: ours (with a PID) and mkstemp's."""
    escaped = re.escape(name)
    return re.compile(rf'\.{escaped}-(?:(\d+)-[0-9a-f]{{8}}|[a-z0-9_]{{8}})\.tmp\Z')


def _running(pid):
    """Return whether process ``pid`` runs (one of another user counts as running)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def stale_temporaries(final):
    """Return the temporaries of ``final`` that no running write owns."""
    folder, name = os.path.split(os.path.abspath(final))
    pattern = _temporary_pattern(name)
    try:
        entries = os.listdir(folder)
    except OSError:
        return []
    stale = []
    for entry in entries:
        match = pattern.match(entry)
        if match is None:
            continue
        path = os.path.join(folder, entry)
        pid = match.group(1)
        if pid is None or path not in _IN_FLIGHT and (
                int(pid) == os.getpid() or not _running(int(pid))):
            stale.append(path)
    return stale


def _remove(path):
    """Remove a file or a folder tree, if it is there."""
    if os.path.isdir(path) and not os.path.islink(path):
        shutil.rmtree(path, ignore_errors=True)
    else:
        try:
            os.unlink(path)
        except FileNotFoundError:
            pass


def remove_stale_temporaries(final):
    """Remove what killed writes of ``final`` left behind (best effort)."""
    for path in stale_temporaries(final):
        try:
            _remove(path)
        except OSError:
            pass


def same_file(path, other):
    """Return whether two paths name one existing file or folder (device and inode)."""
    try:
        return os.path.samefile(path, other)
    except (OSError, ValueError):
        return False


def _fsync_tree(path):
    """Flush a written file, or every file of a written folder and the folder, to disk."""
    paths = [path]
    if os.path.isdir(path):
        paths = [os.path.join(root, name) for root, _, names in os.walk(path) for name in names]
        paths += [root for root, _, _ in os.walk(path)]
    for each in paths:
        fd = os.open(each, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


class Outputs:
    """
    The outputs of one command, written under temporary names and renamed together.

    Use as a context manager: ``path(final)`` checks an output and returns
    the temporary name to write it to (not created: a file or a bag folder
    may be made there); leaving the block without an exception renames
    every temporary into place, an exception (Ctrl-C too) removes them.
    """

    def __init__(self, inputs=(), force=False):
        """Refuse outputs that are one of ``inputs``; replace existing ones only with ``force``."""
        self.inputs = [str(p) for p in inputs if p is not None]
        self.force = force
        self._pending = {}

    def check(self, final):
        """Raise OutputError unless ``final`` may be written; return its absolute path."""
        final = os.path.abspath(os.path.expanduser(str(final)))
        if final in self._pending:
            raise OutputError(f'{final} is named twice as an output')
        for source in self.inputs:
            if same_file(final, source):
                raise OutputError(f'{final} is the input {source}: an input is never '
                                  'overwritten (not even with --force); name another output')
        if os.path.lexists(final) and not self.force:
            raise OutputError(f'{final} exists already: give another name, or --force to '
                              'replace it')
        return final

    def path(self, final):
        """
        Return where to write the output ``final``: its name in a new temporary folder.

        Nothing is created there: a file or a bag folder may be made.
        OutputError when ``final`` may not be written.
        """
        final = self.check(final)
        os.makedirs(os.path.dirname(final), exist_ok=True)
        remove_stale_temporaries(final)
        folder = temporary_path(final)
        os.mkdir(folder)
        _IN_FLIGHT.add(folder)
        temporary = os.path.join(folder, os.path.basename(final))
        self._pending[final] = temporary
        return temporary

    def __enter__(self):
        """Start collecting outputs."""
        return self

    def __exit__(self, kind, value, traceback):
        """Rename every output into place, or remove them all on an exception."""
        if kind is None:
            try:
                self.commit()
            except BaseException:
                self.discard()
                raise
        else:
            self.discard()
        return False

    def commit(self):
        """Flush every written temporary to disk, then rename it into place."""
        written = {final: tmp for final, tmp in self._pending.items() if os.path.lexists(tmp)}
        for tmp in written.values():
            _fsync_tree(tmp)
        for final in written:
            if os.path.lexists(final) and not self.force:
                raise OutputError(f'{final} appeared while it was being written: left as it is')
        folders = set()
        for final, tmp in written.items():
            self._replace(tmp, final)
            folders.add(os.path.dirname(final))
        for folder in folders:
            _fsync_tree(folder)
        self.discard()

    @staticmethod
    def _replace(tmp, final):
        """Rename ``tmp`` to ``final``, moving an existing folder (or file, for a folder) aside."""
        folder_there = os.path.isdir(final) and not os.path.islink(final)
        if not folder_there and not (os.path.isdir(tmp) and os.path.lexists(final)):
            os.replace(tmp, final)  # atomic, over a file too
            return
        aside = temporary_path(final)
        os.replace(final, aside)
        try:
            os.replace(tmp, final)
        except BaseException:
            os.replace(aside, final)
            raise
        _remove(aside)

    def discard(self):
        """Remove the temporary folders (and what was not renamed into place)."""
        for tmp in self._pending.values():
            folder = os.path.dirname(tmp)
            try:
                _remove(folder)
            except OSError:
                pass
            _IN_FLIGHT.discard(folder)
        self._pending.clear()


def write_text(path, text, inputs=(), force=True):
    """Write ``text`` to ``path`` whole (a temporary renamed into place)."""
    with Outputs(inputs, force) as outputs:
        with open(outputs.path(path), 'x') as stream:
            stream.write(text)


def write_json(path, doc, inputs=(), force=True):
    """Write ``doc`` as indented JSON to ``path`` whole."""
    write_text(path, json.dumps(doc, indent=2) + '\n', inputs, force)


def _unique_keys(pairs):
    """Return the object of ``pairs``; ValueError for a key that appears twice."""
    doc = {}
    for key, value in pairs:
        if key in doc:
            raise ValueError(f'the key {key!r} appears twice in one object')
        doc[key] = value
    return doc


def loads_strict(data):
    """Return the JSON document ``data`` (str or bytes); ValueError for a key repeated."""
    return json.loads(data, object_pairs_hook=_unique_keys)


def read_json(path, max_bytes=MAX_JSON_BYTES):
    """
    Return the JSON document in the file ``path``, read strictly (``loads_strict``).

    Raises FileNotFoundError when there is no file, ValueError with the reason
    when there is one that cannot be read or is not one JSON document (a
    repeated key, more than ``max_bytes``, undecodable bytes, nesting too deep).
    """
    try:
        with open(path, 'rb') as stream:
            data = stream.read(max_bytes + 1)
    except FileNotFoundError:
        raise
    except OSError as err:
        raise ValueError(f'cannot be read ({err})') from None
    if len(data) > max_bytes:
        raise ValueError(f'cannot be read (larger than {max_bytes} bytes: not a file of ours)')
    try:
        # From bytes, so undecodable garbage is a ValueError (UnicodeDecodeError) here too.
        return loads_strict(data)
    except (ValueError, RecursionError) as err:
        raise ValueError(f'not valid JSON ({err})') from None
