"""
Files written whole or not at all, never over an input or silently over another file.

Every file and bag the package writes goes through ``Outputs``: each output is
written, under its own name, into a temporary folder beside it
(``.NAME-PID-<random>.tmp/NAME``; a NAME too long for that is cut and
hashed, ``_temporary_stem``) and renamed into place only when the command
completed; on any failure, Ctrl-C included, the temporaries are removed and
what existed stays as it was.  The outputs of one command land together or
none does: an output already renamed into place is put back as it was when a
later one cannot be (``Outputs.commit``).  Only the written file (or bag
folder) and the folder it lands in are flushed to disk, nothing else of that
folder (a FIFO or 20 000 other files beside an output cost nothing).

An output that exists already is refused unless ``force`` is given, and even
then only a regular file or a bag folder (``is_bag_folder``) is replaced,
never a folder holding anything else, a FIFO or a device; an output that is
one of the command's inputs (the same file, found by device and inode, so a
link or another spelling of the name is caught too) or a folder holding one
is refused even then (``replace_refusal``).  Temporaries a killed process
left behind (its PID no longer runs, or an older name without a PID) are
removed at the next write of the same output.

Files are read only when they are regular files (``open_regular``): a FIFO or
a device named as an input is refused at once, never waited on.  JSON
documents are read with ``loads_strict``: a key that appears twice in an
object is an error, not "the last one wins".
"""

import hashlib
import json
import os
import re
import secrets
import shutil
import stat


#: Largest JSON file ``read_json`` reads: calibration and station files are kilobytes.
MAX_JSON_BYTES = 16 * 1024 * 1024


class OutputError(Exception):
    """An output that must not be written: it exists already, or it is an input."""


class NotRegularFile(OSError):
    """A path to read that is not a regular file (a FIFO, a device, a socket, a folder)."""


#: What a path of each kind of file that is not a regular one is called in a message.
_KINDS = ((stat.S_ISFIFO, 'a FIFO'), (stat.S_ISCHR, 'a character device'),
          (stat.S_ISBLK, 'a block device'), (stat.S_ISSOCK, 'a socket'),
          (stat.S_ISDIR, 'a folder'), (stat.S_ISLNK, 'a symbolic link'))


def file_kind(mode):
    """Return what a file of ``st_mode`` is called, 'a regular file' for one."""
    for test, name in _KINDS:
        if test(mode):
            return name
    return 'a regular file' if stat.S_ISREG(mode) else 'not a regular file'


def open_regular(path, mode='rb', **kwargs):
    """
    Open ``path`` for reading, only if it is a regular file (``open`` otherwise).

    The type is checked on the opened descriptor (no race with a rename):
    opening never blocks (O_NONBLOCK, which a FIFO would otherwise wait on
    for a writer), and anything but a regular file is NotRegularFile.
    """
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        kind = os.fstat(fd).st_mode
        if not stat.S_ISREG(kind):
            raise NotRegularFile(f'{path} is {file_kind(kind)}, not a regular file: refused, '
                                 'nothing read')
        os.set_blocking(fd, True)
        return open(fd, mode, **kwargs)
    except BaseException:
        os.close(fd)
        raise


#: Outputs of this process being written now: their temporaries are not stale.
_IN_FLIGHT = set()


#: The longest file name in bytes (POSIX NAME_MAX of ext4, xfs, btrfs, tmpfs).
NAME_MAX = 255
#: Bytes a temporary adds to its stem: '.', '-PID' (up to 10 digits), '-<8 hex>', '.tmp'.
_TEMPORARY_EXTRA = 1 + 11 + 9 + 4
#: Hex digits of the SHA-256 of the name that stand for a long name's cut tail.
_NAME_HASH_DIGITS = 12


def fitting_name(name, extra_bytes):
    """
    Return ``name``, or a shortened stand-in for it, such that ``extra_bytes`` more fit NAME_MAX.

    The name itself when it fits, else its first bytes and '~' with a hash of
    the whole name: any name the OS accepts (up to 255 bytes) has a derived
    name (a temporary, a history folder) the OS accepts too, found again from
    the name alone, and distinct from the one of another name with the same
    beginning.
    """
    encoded = os.fsencode(name)
    if len(encoded) + extra_bytes <= NAME_MAX:
        return name
    digest = hashlib.sha256(encoded).hexdigest()[:_NAME_HASH_DIGITS]
    keep = NAME_MAX - extra_bytes - 1 - _NAME_HASH_DIGITS
    return f'{os.fsdecode(encoded[:keep])}~{digest}'


def _temporary_stem(name):
    """Return the part of ``name`` its temporaries start with (recognised by the stale cleanup)."""
    return fitting_name(name, _TEMPORARY_EXTRA)


def temporary_path(final):
    """Return a new temporary name beside ``final`` (the file is not created)."""
    folder, name = os.path.split(os.path.abspath(final))
    stem = _temporary_stem(name)
    return os.path.join(folder, f'.{stem}-{os.getpid()}-{secrets.token_hex(4)}.tmp')


def _temporary_pattern(name):
    """Return the regex of the temporaries of ``name``: ours (with a PID) and mkstemp's."""
    escaped = re.escape(_temporary_stem(name))
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


def _fsync(path, flags=os.O_RDONLY):
    """Flush one file or folder to disk."""
    fd = os.open(path, flags | os.O_CLOEXEC)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _fsync_written(path):
    """
    Flush a written temporary to disk: the file, or the files and folders of a bag folder.

    Only what this process wrote is opened (its own temporary tree), and only
    regular files and folders of it: nothing else is ever opened.
    """
    if stat.S_ISREG(os.lstat(path).st_mode):
        _fsync(path)
        return
    for root, _, names in os.walk(path):
        for name in names:
            each = os.path.join(root, name)
            if stat.S_ISREG(os.lstat(each).st_mode):
                _fsync(each)
        _fsync(root, os.O_RDONLY | os.O_DIRECTORY)


def fsync_folder(folder):
    """Flush a folder's entries (a rename into it) to disk; best effort."""
    try:
        _fsync(folder, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        pass


#: The files a bag folder written by this package holds (rosbags: metadata.yaml and storage).
BAG_FILE_SUFFIXES = ('.mcap', '.db3')


def is_bag_folder(path):
    """
    Return whether ``path`` is a folder that holds a rosbag2 bag and nothing else.

    Its ``metadata.yaml`` and storage files (``.mcap``, ``.db3``), all regular
    files: what ``--force`` may replace as an output bag.
    """
    try:
        entries = list(os.scandir(path))
    except OSError:
        return False
    names = {entry.name for entry in entries}
    return 'metadata.yaml' in names and all(
        entry.is_file(follow_symlinks=False) and (
            entry.name == 'metadata.yaml' or entry.name.endswith(BAG_FILE_SUFFIXES))
        for entry in entries)


def _holds(folder, path):
    """Return whether ``path`` is ``folder`` or lies inside it (links resolved)."""
    folder, path = os.path.realpath(folder), os.path.realpath(path)
    return path == folder or path.startswith(folder.rstrip(os.sep) + os.sep)


def input_refusal(final, inputs=()):
    """Return why ``final`` may never be written: it is an input or a folder holding one."""
    for source in inputs:
        if same_file(final, source):
            return (f'{final} is the input {source}: an input is never overwritten (not even '
                    'with --force); name another output')
        if os.path.isdir(final) and not os.path.islink(final) and _holds(final, source):
            return (f'{final} is a folder holding the input {source}: it is never replaced '
                    '(not even with --force); name another output')
    return None


def replace_refusal(final, inputs=()):
    """
    Return why the existing ``final`` may not be replaced (even with force), None if it may.

    Only a regular file (or a link) or a bag folder (``is_bag_folder``) is an
    output to replace; never one of ``inputs`` nor a folder holding one.
    """
    reason = input_refusal(final, inputs)
    if reason is not None:
        return reason
    try:
        kind = os.lstat(final).st_mode
    except FileNotFoundError:
        return None
    if stat.S_ISREG(kind) or stat.S_ISLNK(kind):
        return None
    if stat.S_ISDIR(kind):
        if is_bag_folder(final):
            return None
        return (f'{final} is a folder that is not a bag (it holds other files): --force '
                'replaces only a file or a bag, never such a folder; name another output')
    return f'{final} is {file_kind(kind)}, not a file: it is never replaced; name another output'


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
        self._new = set()
        self._updates = set()
        self._conditions = []
        self._afterwards = []

    def require(self, condition):
        """Call ``condition()`` at the commit, before any rename: what it raises aborts it."""
        self._conditions.append(condition)

    def after(self, action):
        """Call ``action()`` once every output has landed (not when the commit fails)."""
        self._afterwards.append(action)

    def check(self, final, new=False, update=False):
        """
        Raise OutputError unless ``final`` may be written; return its absolute path.

        ``new``: the output must not exist, even with force (a history entry);
        ``update``: it is the file the command read to change it (a
        calibration file), not an input it must leave alone.
        """
        final = os.path.abspath(os.path.expanduser(str(final)))
        if final in self._pending:
            raise OutputError(f'{final} is named twice as an output')
        inputs = () if update else self.inputs
        reason = input_refusal(final, inputs)
        if reason is not None:
            raise OutputError(reason)
        if os.path.lexists(final) and (new or not (self.force or update)):
            raise OutputError(f'{final} exists already: give another name' + (
                '' if new else ', or --force to replace it'))
        reason = replace_refusal(final, inputs)
        if reason is not None:
            raise OutputError(reason)
        return final

    def path(self, final, new=False, update=False):
        """
        Return where to write the output ``final``: its name in a new temporary folder.

        Nothing is created there: a file or a bag folder may be made.
        OutputError when ``final`` may not be written (``check``).
        """
        final = self.check(final, new, update)
        os.makedirs(os.path.dirname(final), exist_ok=True)
        remove_stale_temporaries(final)
        folder = temporary_path(final)
        os.mkdir(folder)
        _IN_FLIGHT.add(folder)
        temporary = os.path.join(folder, os.path.basename(final))
        self._pending[final] = temporary
        if new:
            self._new.add(final)
        if update:
            self._updates.add(final)
        return temporary

    def pending(self, suffix=''):
        """Return (final, temporary) of the outputs written so far named ``*suffix``."""
        return [(final, tmp) for final, tmp in self._pending.items()
                if final.endswith(suffix) and os.path.lexists(tmp)]

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
        """
        Flush every written temporary to disk, then rename them all into place, or none.

        An output whose rename fails puts every one renamed before it back as it
        was (the replaced files were kept aside until then), and the error is
        raised: what is on disk is then what was there before the command.
        """
        written = {final: tmp for final, tmp in self._pending.items() if os.path.lexists(tmp)}
        for tmp in written.values():
            _fsync_written(tmp)
        for condition in self._conditions:
            condition()
        for final in written:
            update = final in self._updates
            if os.path.lexists(final) and (final in self._new or not (self.force or update)):
                raise OutputError(f'{final} appeared while it was being written: left as it is')
            reason = replace_refusal(final, () if update else self.inputs)
            if reason is not None:  # changed into something else while this command ran
                raise OutputError(reason)
        done = []
        try:
            for final, tmp in written.items():
                done.append((final, self._replace(tmp, final)))
        except BaseException:
            for final, aside in reversed(done):
                _put_back(final, aside)
            raise
        for folder in {os.path.dirname(final) for final in written}:
            fsync_folder(folder)
        for _, aside in done:
            if aside is not None:
                _remove(aside)
                _IN_FLIGHT.discard(aside)
        self.discard()
        for action in self._afterwards:
            action()

    @staticmethod
    def _replace(tmp, final):
        """
        Rename ``tmp`` to ``final``; return where the replaced one is kept (None: there was none).

        A replaced file keeps its place until the rename (a hard link keeps it
        aside: a reader sees old or new, whole); a replaced folder, or a file
        a folder replaces, is moved aside first.
        """
        if not os.path.lexists(final):
            os.replace(tmp, final)
            return None
        aside = temporary_path(final)
        _IN_FLIGHT.add(aside)
        if os.path.isdir(tmp) or os.path.isdir(final) and not os.path.islink(final):
            os.replace(final, aside)
            try:
                os.replace(tmp, final)
            except BaseException:
                os.replace(aside, final)
                raise
            return aside
        try:
            os.link(final, aside, follow_symlinks=False)
        except OSError:  # a file system without hard links
            shutil.copy2(final, aside, follow_symlinks=False)
        try:
            os.replace(tmp, final)  # atomic, over a file too
        except BaseException:
            _remove(aside)
            raise
        return aside

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


def _put_back(final, aside):
    """Undo the rename of an output: what was at ``final`` (kept at ``aside``) returns."""
    try:
        if aside is None:
            _remove(final)
        elif os.path.isdir(aside) and not os.path.islink(aside) or (
                os.path.isdir(final) and not os.path.islink(final)):
            trash = temporary_path(final)
            os.replace(final, trash)
            os.replace(aside, final)
            _remove(trash)
        else:
            os.replace(aside, final)
    except OSError:  # best effort: the error being raised says the command failed
        pass
    _IN_FLIGHT.discard(aside)


def write_text(path, text, inputs=(), force=True, outputs=None, new=False, update=False):
    """
    Write ``text`` to ``path`` whole (a temporary renamed into place).

    With ``outputs`` (an open ``Outputs``) the file is one output of that
    command, renamed into place with its others; ``new``: it must not exist;
    ``update``: it is the file read to be changed (``Outputs.check``).
    """
    if outputs is None:
        with Outputs(inputs, force) as own:
            return write_text(path, text, outputs=own, new=new, update=update)
    with open(outputs.path(path, new, update), 'x', encoding='utf-8') as stream:
        stream.write(text)


def write_json(path, doc, inputs=(), force=True, outputs=None, new=False):
    """Write ``doc`` as indented JSON to ``path`` whole (``write_text``)."""
    write_text(path, json.dumps(doc, indent=2) + '\n', inputs, force, outputs, new)


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


def read_json(path, max_bytes=MAX_JSON_BYTES, with_digest=False):
    """
    Return the JSON document in the file ``path``, read strictly (``loads_strict``).

    Raises FileNotFoundError when there is no file, ValueError with the reason
    when there is one that cannot be read or is not one JSON document (a
    repeated key, more than ``max_bytes``, undecodable bytes, nesting too deep,
    not a regular file).  ``with_digest``: return (document, SHA-256 hex
    digest of the bytes read), both of one read.
    """
    try:
        with open_regular(path) as stream:
            data = stream.read(max_bytes + 1)
    except FileNotFoundError:
        raise
    except OSError as err:
        raise ValueError(f'cannot be read ({err})') from None
    if len(data) > max_bytes:
        raise ValueError(f'cannot be read (larger than {max_bytes} bytes: not a file of ours)')
    try:
        # From bytes, so undecodable garbage is a ValueError (UnicodeDecodeError) here too.
        doc = loads_strict(data)
    except (ValueError, RecursionError) as err:
        raise ValueError(f'not valid JSON ({err})') from None
    return (doc, hashlib.sha256(data).hexdigest()) if with_digest else doc
