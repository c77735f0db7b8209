"""
Outputs written whole, never over an input, never silently over another file (``io.files``).

The commands' own cases (``inclino msa IN.csv -o IN.csv`` and the like) are in
``test_reliability_cli.py``; here the mechanism they share.
"""

import json
import os
import subprocess
import sys

from inclino_ros.calibration.model import (
    CalibrationFileError, CalibrationModel, load_model, save_model)
from inclino_ros.calibration.stations import load_stations, save_stations, StationsFileError
from inclino_ros.io.files import (
    loads_strict, OutputError, Outputs, stale_temporaries, temporary_path)
import pytest


def dead_pid():
    """Return the PID of a process that has ended."""
    child = subprocess.Popen([sys.executable, '-c', 'pass'])
    child.wait()
    return child.pid


def test_existing_output_refused_unless_forced(tmp_path):
    """An existing file or bag folder is refused (and left as it was); force replaces it."""
    csv, bag = tmp_path / 'out.csv', tmp_path / 'bag'
    csv.write_text('old')
    bag.mkdir()
    (bag / 'metadata.yaml').write_text('old')
    (bag / 'bag_0.mcap').write_text('old')
    for final in (csv, bag):
        with pytest.raises(OutputError, match='exists already'):
            with Outputs() as outputs:
                outputs.path(final)
    assert csv.read_text() == 'old' and sorted(os.listdir(bag)) == ['bag_0.mcap', 'metadata.yaml']
    with Outputs(force=True) as outputs:
        with open(outputs.path(csv), 'x') as stream:
            stream.write('new')
        os.mkdir(outputs.path(bag))
    assert csv.read_text() == 'new' and os.listdir(bag) == []
    assert sorted(os.listdir(tmp_path)) == ['bag', 'out.csv']


@pytest.mark.parametrize('spelling', ['same', 'dotted', 'symlink', 'hardlink'])
def test_an_input_is_never_an_output(tmp_path, spelling):
    """The same file by device and inode is refused, even with force; the input is untouched."""
    source = tmp_path / 'stations.csv'
    source.write_text('gx,gy\n1,2\n')
    final = {'same': source, 'dotted': tmp_path / '.' / 'sub' / '..' / 'stations.csv',
             'symlink': tmp_path / 'link.csv', 'hardlink': tmp_path / 'hard.csv'}[spelling]
    (tmp_path / 'sub').mkdir()
    if spelling == 'symlink':
        final.symlink_to(source)
    elif spelling == 'hardlink':
        os.link(source, final)
    with pytest.raises(OutputError, match='is the input'):
        with Outputs(inputs=[str(source)], force=True) as outputs:
            outputs.path(final)
    assert source.read_text() == 'gx,gy\n1,2\n'


def test_failure_removes_the_temporaries(tmp_path):
    """An exception (Ctrl-C too) while writing leaves no output and no temporary."""
    (tmp_path / 'b.csv').write_text('previous')
    for error in (RuntimeError, KeyboardInterrupt):
        with pytest.raises(error):
            with Outputs(force=True) as outputs:
                open(outputs.path(tmp_path / 'a.csv'), 'w').write('half')
                os.mkdir(outputs.path(tmp_path / 'bag'))
                open(outputs.path(tmp_path / 'b.csv'), 'w').write('half')
                raise error()
        assert sorted(os.listdir(tmp_path)) == ['b.csv']
        assert (tmp_path / 'b.csv').read_text() == 'previous'


def test_stale_temporaries_of_killed_writes_are_removed(tmp_path):
    """Temporaries of a dead PID or the old mkstemp naming go at the next write; live ones stay."""
    path = tmp_path / 'calibration.json'
    dead = dead_pid()
    stale = [tmp_path / f'.calibration.json-{dead}-0123abcd.tmp',
             tmp_path / '.calibration.json-k2_x9qzz.tmp']
    live = tmp_path / f'.calibration.json-{os.getppid()}-89abcdef.tmp'
    other = tmp_path / f'.other.json-{dead}-0123abcd.tmp'
    for leftover in stale + [live, other]:
        leftover.write_text('{')
    (tmp_path / f'.calibration.json-{dead}-4567abcd.tmp').mkdir()
    stale.append(tmp_path / f'.calibration.json-{dead}-4567abcd.tmp')
    assert sorted(stale_temporaries(path)) == sorted(map(str, stale))
    save_model(str(path), CalibrationModel(accelerometer_axes=3))
    assert sorted(os.listdir(tmp_path)) == sorted(['calibration.json', 'calibration.json.history',
                                                   live.name, other.name])
    save_stations(str(tmp_path / 'stations.json'), [])
    assert (tmp_path / 'stations.json').exists()


def test_duplicate_json_keys_are_refused(tmp_path):
    """A key twice in one object ("gamma_deg" hand-edited in again) is a refusal on load."""
    with pytest.raises(ValueError, match="'b' appears twice"):
        loads_strict('{"a": {"b": 1, "b": 2}}')
    path = tmp_path / 'calibration.json'
    save_model(str(path), CalibrationModel(accelerometer_axes=3))
    text = path.read_text().replace('"accelerometer_axes": 3',
                                    '"accelerometer_axes": 3, "accelerometer_axes": 2')
    path.write_text(text)
    with pytest.raises(CalibrationFileError, match='appears twice'):
        load_model(str(path))
    stations = tmp_path / 'stations.json'
    save_stations(str(stations), [])
    stations.write_text(stations.read_text().replace('"stations": []',
                                                     '"stations": [], "stations": []'))
    with pytest.raises(StationsFileError, match='appears twice'):
        load_stations(str(stations))


def test_a_stations_file_that_is_a_folder_is_a_clear_error(tmp_path):
    """A stations path that names a folder is a StationsFileError, not an IsADirectoryError."""
    with pytest.raises(StationsFileError, match='cannot be read'):
        load_stations(str(tmp_path))


def test_oversized_json_is_refused(tmp_path):
    """A calibration file of megabytes is not read whole into memory."""
    path = tmp_path / 'calibration.json'
    path.write_text(json.dumps({'format': 'x', 'pad': ' ' * (17 * 1024 * 1024)}))
    with pytest.raises(CalibrationFileError, match='larger than'):
        load_model(str(path))


def test_outputs_land_together_or_none(tmp_path, monkeypatch):
    """The second rename fails: the first output, already in place, is put back as it was."""
    first, second = tmp_path / 'cal.json', tmp_path / 'report.txt'
    first.write_text('old calibration')
    rename = os.replace

    def failing(source, target):
        if str(target) == str(second):
            raise OSError(30, 'Read-only file system')
        return rename(source, target)

    monkeypatch.setattr(os, 'replace', failing)
    with pytest.raises(OSError, match='Read-only'):
        with Outputs(force=True) as outputs:
            for path, text in ((first, 'new calibration'), (second, 'report')):
                with open(outputs.path(path), 'x') as stream:
                    stream.write(text)
    monkeypatch.undo()
    assert first.read_text() == 'old calibration'
    assert sorted(os.listdir(tmp_path)) == ['cal.json']


@pytest.mark.parametrize('case', ['folder of the user', 'folder holding the input', 'fifo'])
def test_force_replaces_only_what_the_project_writes(tmp_path, case):
    """--force never replaces a folder that is no bag, one holding an input, or a FIFO."""
    project = tmp_path / 'proj'
    project.mkdir()
    (project / 'notes.txt').write_text('mine')
    source = project / 'in.csv'
    source.write_text('gx\n1\n')
    final = {'folder of the user': project, 'folder holding the input': project,
             'fifo': tmp_path / 'pipe'}[case]
    inputs = [str(source)] if case == 'folder holding the input' else []
    if case == 'fifo':
        os.mkfifo(final)
    with pytest.raises(OutputError, match='holding the input|not a bag|FIFO'):
        with Outputs(inputs=inputs, force=True) as outputs:
            outputs.path(final)
    assert sorted(os.listdir(project)) == ['in.csv', 'notes.txt']
    assert (project / 'notes.txt').read_text() == 'mine'


@pytest.mark.parametrize('char', ['a', 'é'])
def test_a_long_output_name_the_os_accepts_is_written(tmp_path, char):
    """A 250-byte name (255 is NAME_MAX) is written; its temporary fits and is found when stale."""
    name = char * ((250 - len('.csv')) // len(char.encode())) + '.csv'
    final = tmp_path / name
    assert 245 <= len(os.fsencode(name)) <= 250
    final.write_text('accepted by the OS')
    final.unlink()
    with Outputs() as outputs:
        with open(outputs.path(final), 'x') as stream:
            stream.write('new')
    assert os.listdir(tmp_path) == [name] and final.read_text() == 'new'
    mine = temporary_path(str(final))
    assert len(os.fsencode(os.path.basename(mine))) <= 255
    stale = mine.replace(f'-{os.getpid()}-', f'-{dead_pid()}-')
    os.mkdir(stale)
    other = tmp_path / os.path.basename(temporary_path(str(tmp_path / (name[:-4] + '.txt'))))
    other.mkdir()
    assert stale_temporaries(final) == [stale]
    with Outputs(force=True) as outputs:
        open(outputs.path(final), 'w').write('newer')
    assert sorted(os.listdir(tmp_path)) == sorted([name, other.name])
