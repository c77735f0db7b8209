"""
Every version of a calibration file, kept beside it: no calibration is ever lost.

The history of ``FILE`` is the folder ``FILE.history`` (a long name's is
shortened, ``history_folder``): one JSON file per
version ever written by ``model.save_model`` (the one door of every write: the
node's services, every ``inclino fit-*``, ``inclino msa``, ``inclino
calibration restore``), ``v000001.json``, ``v000002.json``, ... Each holds the
version's exact text, its SHA-256 digest, when and by what it was written and
the sensor it belongs to.  A version found on disk that the history does not
hold as its newest (a file written before the history, by hand, or by an
older release) is kept first, as written by ``unknown``.

Each version is its own file, written whole (``io.files``) in the same commit
as the calibration file and before it is renamed into place: a kill -9 at any
point leaves the file and every version valid (at worst the history holds the
new version while the file still is the previous one, which the history also
holds).  A damaged or unreadable version (its digest does not match its text,
its text is no calibration) is reported by ``read_history`` and skipped; it
never blocks loading the calibration file itself.

The history keeps the newest ``keep`` versions (``DEFAULT_KEEP``, the node's
``calibration.history_keep`` and the commands' ``--history-keep``): after a
write has landed, ``prune`` removes the older ones, oldest first, each
removal atomic, so a kill at any point leaves a valid history that still
holds the newest versions; the version the file holds now (in use) and the
newest are never removed, whatever ``keep``.
"""

from dataclasses import dataclass
import hashlib
import os
import re

from inclino_ros.io.files import (
    fitting_name, fsync_folder, loads_strict, MAX_JSON_BYTES, open_regular, read_json,
    write_json)

FORMAT = 'inclino_ros.calibration_version'
SCHEMA_VERSION = 1
#: Writer of a version found on disk that no write through ``save_model`` recorded.
UNKNOWN_WRITER = 'unknown (found on disk, not written through inclino_ros)'
#: What a calibration file's name gets for its history folder's.
_SUFFIX = '.history'
_ENTRY = re.compile(r'v(\d{6,})\.json\Z')
#: Versions a history keeps by default: a write a day for more than half a year.
DEFAULT_KEEP = 200


@dataclass(frozen=True)
class Version:
    """One version of a calibration file."""

    number: int
    written_at: str
    writer: str
    sensor_id: str
    sha256: str
    text: str


def digest(text):
    """Return the SHA-256 hex digest of ``text`` (str, UTF-8, or bytes)."""
    data = text.encode('utf-8') if isinstance(text, str) else text
    return hashlib.sha256(data).hexdigest()


def history_folder(path):
    """
    Return the history folder of the calibration file ``path``: ``path.history``.

    For a name so long that ``NAME.history`` passes the file system's 255
    bytes, ``NAME'~HASH.history``: its first bytes and a hash of the whole
    name (``io.files.fitting_name``), derived from the name alone, so every
    reader finds it again.
    """
    folder, name = os.path.split(os.path.abspath(os.path.expanduser(path)))
    return os.path.join(folder, fitting_name(name, len(_SUFFIX)) + _SUFFIX)


def current_bytes(path):
    """Return the bytes of the calibration file ``path`` now; None when there is none."""
    try:
        with open_regular(os.path.expanduser(path)) as stream:
            return stream.read(MAX_JSON_BYTES + 1)
    except FileNotFoundError:
        return None


def file_digest(path):
    """Return the digest of the calibration file ``path`` as it is now; None when there is none."""
    data = current_bytes(path)
    return None if data is None else digest(data)


def _numbers(folder):
    """Return {number: entry path} of the version files in ``folder`` (OSError if unreadable)."""
    numbers = {}
    for name in os.listdir(folder):
        match = _ENTRY.match(name)
        if match:
            numbers[int(match.group(1))] = os.path.join(folder, name)
    return numbers


def _version(number, path, validate):
    """Return the Version in ``path``; ValueError naming what is wrong with it."""
    try:
        doc = read_json(path)
    except (FileNotFoundError, ValueError) as err:
        raise ValueError(str(err)) from None
    if not isinstance(doc, dict) or doc.get('format') != FORMAT:
        raise ValueError(f'not an {FORMAT} document')
    try:
        version = Version(number=number, **{key: doc[key] for key in (
            'written_at', 'writer', 'sensor_id', 'sha256', 'text')})
    except KeyError as err:
        raise ValueError(f'no {err.args[0]!r}') from None
    if not isinstance(version.text, str) or digest(version.text) != version.sha256:
        raise ValueError('its text does not match its sha256 digest')
    validate(version.text)
    return version


def read_history(path, validate=lambda text: None):
    """
    Return (versions, problems) of the calibration file ``path``: oldest first.

    ``validate(text)`` raises ValueError for a text that is no valid
    calibration.  Never raises for a damaged history: a folder that cannot
    be read, or a version that is damaged, is one line of ``problems``.
    """
    folder = history_folder(path)
    if not os.path.lexists(folder):
        return [], []
    try:
        numbers = _numbers(folder)
    except OSError as err:
        return [], [f'the history {folder} cannot be read ({err})']
    versions, problems = [], []
    for number in sorted(numbers):
        try:
            versions.append(_version(number, numbers[number], validate))
        except ValueError as err:
            problems.append(f'version {number} ({numbers[number]}) is damaged: {err}')
    return versions, problems


def record(path, text, writer, sensor_id, written_at, outputs):
    """
    Add the new ``text`` of ``path`` (and the one on disk, if the history lacks it) to ``outputs``.

    The versions are new outputs of the same commit (``io.files.Outputs``)
    as the calibration file, renamed into place before it.  OSError when the
    history folder cannot be made (then nothing is written).
    """
    folder = history_folder(path)
    os.makedirs(folder, exist_ok=True)
    numbers = _numbers(folder)
    versions, _ = read_history(path)
    on_disk = current_bytes(path)
    number = max(numbers, default=0)
    entries = []
    if on_disk is not None and (not versions or versions[-1].sha256 != digest(on_disk)):
        found = on_disk.decode('utf-8', errors='replace')
        entries.append((UNKNOWN_WRITER, sensor_id_of(found), found))
    entries.append((writer, sensor_id, text))
    for writer_name, sensor, content in entries:
        number += 1
        write_json(os.path.join(folder, f'v{number:06d}.json'), {
            'format': FORMAT, 'schema_version': SCHEMA_VERSION, 'written_at': written_at,
            'writer': writer_name, 'sensor_id': sensor, 'sha256': digest(content),
            'text': content}, outputs=outputs, new=True)


def prune(path, keep, in_use=()):
    """
    Remove the versions of ``path``'s history older than its newest ``keep``; return their numbers.

    Never removed: the newest version, the one the file holds now, and any
    whose digest is in ``in_use`` (e.g. the model a node runs with).  Oldest
    first, each one removal (atomic): a kill at any point leaves a valid
    history holding every version kept.  A damaged version counts as one.
    OSError when the history cannot be read.
    """
    folder = history_folder(path)
    if not os.path.isdir(folder):
        return []
    numbers = _numbers(folder)
    kept = set(sorted(numbers)[-max(int(keep), 1):])
    digests = {number: _sha256_of(entry) for number, entry in numbers.items()}
    for wanted in set(in_use) | {file_digest(path)}:
        holding = [number for number, sha256 in digests.items() if sha256 == wanted]
        if holding:
            kept.add(max(holding))   # the version in use: the newest that holds it
    pruned = []
    for number in sorted(set(numbers) - kept):
        try:
            os.unlink(numbers[number])
        except FileNotFoundError:   # another writer pruned it meanwhile
            continue
        pruned.append(number)
    if pruned:
        fsync_folder(folder)
    return pruned


def _sha256_of(entry):
    """Return the digest of the version file ``entry``; None when it is damaged."""
    try:
        return _version(0, entry, lambda text: None).sha256
    except ValueError:
        return None


def pruned_message(path, numbers, keep):
    """Return the line that says which versions of ``path``'s history ``prune`` removed."""
    spans, start = [], None
    for i, number in enumerate(numbers):
        start = number if start is None else start
        if i + 1 == len(numbers) or numbers[i + 1] != number + 1:
            spans.append(str(number) if start == number else f'{start}-{number}')
            start = None
    return (f'{path}: removed version{"s" if len(numbers) > 1 else ""} {", ".join(spans)} from '
            f'its history (it keeps the newest {keep}, and the version in use)')


def sensor_id_of(text):
    """Return the sensor_id a calibration text names, None when it names none or is no JSON."""
    try:
        doc = loads_strict(text)
    except (ValueError, RecursionError):
        return None
    sensor = doc.get('sensor_id') if isinstance(doc, dict) else None
    return sensor if isinstance(sensor, str) else None
