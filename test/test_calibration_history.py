"""
Issue 23 item 2: every write of a calibration file keeps its versions (``calibration.history``).

Each version the file ever had is in ``FILE.history``; ``inclino calibration``
lists, restores and compares them; a damaged history never blocks loading
the file; kill -9 at any point of a write leaves the file and every version
valid.  Before, every write replaced the file and the previous calibration
was gone.
"""

import math
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time

from inclino_ros.calibration import history
from inclino_ros.calibration.history import digest, history_folder
from inclino_ros.calibration.model import (
    CalibrationModel, load_model, read_model_history, save_model)
from inclino_ros.node.parameters import PARAMETERS
import numpy as np
import pytest
from ros_harness import installed_script, tilted_reading
from test_msa_cli import quiet

INCLINO = installed_script('inclino')
GAMMA_DEG, BETA_DEG = 0.8, -1.2
NOISE_MPS2 = 0.002


def level_csv(path, gamma_deg=GAMMA_DEG, beta_deg=BETA_DEG, samples=600, seed=1):
    """Write fit-level's CSV: the tool still on a level bench, installed with (gamma, beta)."""
    rng = np.random.default_rng(seed)
    level = tilted_reading(0.0, 0.0, gamma_deg, beta_deg)
    rows = level + rng.normal(0.0, NOISE_MPS2, (samples, 3))
    with open(path, 'w') as stream:
        stream.write('time_s,ax,ay,az\n')
        for i, row in enumerate(rows):
            stream.write(f'{i * 0.005:.3f},{row[0]:.6f},{row[1]:.6f},{row[2]:.6f}\n')
    return str(path)


def fit_level(csv, calibration, *extra):
    """Run ``inclino fit-level`` in-process; return (code, out, err)."""
    return quiet(['fit-level', csv, '--calibration', calibration, *extra])


def test_every_write_keeps_the_version_it_replaces(tmp_path):
    """A Python save, two fit-levels and a hand edit: every version is in the history, whole."""
    calibration = str(tmp_path / 'cal.json')
    save_model(calibration, CalibrationModel(3, sensor_id='SN1'))
    texts = [open(calibration).read()]
    assert fit_level(level_csv(tmp_path / 'a.csv'), calibration, '--sensor-id', 'SN1')[0] == 0
    texts.append(open(calibration).read())
    # A hand edit (or an older release) between two writes: kept as found on disk.
    edited = texts[-1].replace('"sensor_id": "SN1"', '"sensor_id": "SN1" ')
    with open(calibration, 'w') as stream:
        stream.write(edited)
    texts.append(edited)
    assert fit_level(level_csv(tmp_path / 'b.csv', gamma_deg=0.5), calibration,
                     '--sensor-id', 'SN1')[0] == 0
    texts.append(open(calibration).read())
    versions, problems = read_model_history(calibration)
    assert problems == []
    assert [v.text for v in versions] == texts
    assert [v.number for v in versions] == [1, 2, 3, 4]
    assert [v.writer.split(' (')[0] for v in versions] == [
        'python', 'inclino fit-level', 'unknown', 'inclino fit-level']
    assert all(v.sha256 == digest(v.text) and v.sensor_id == 'SN1' for v in versions)
    assert load_model(calibration).installation.gamma_deg == pytest.approx(0.5, abs=0.01)


def test_history_restore_and_diff(tmp_path):
    """List the versions; restore brings one back as a new version; diff compares two."""
    calibration = str(tmp_path / 'cal.json')
    assert fit_level(level_csv(tmp_path / 'a.csv'), calibration)[0] == 0
    assert fit_level(level_csv(tmp_path / 'b.csv', gamma_deg=-0.4, beta_deg=0.3),
                     calibration)[0] == 0
    code, out, err = quiet(['calibration', 'history', calibration])
    assert code == 0, err
    rows = [line for line in out.splitlines() if re.match(r'\s+\d+ ', line)]
    assert len(rows) == 2 and all('by inclino fit-level' in row for row in rows)
    assert 'stages: installation' in rows[0] and rows[1].endswith('<- the file now')

    first = load_model(calibration)  # version 2
    code, out, err = quiet(['calibration', 'restore', calibration, '1'])
    assert code == 0, err
    restored = load_model(calibration)
    assert restored.installation.gamma_deg == pytest.approx(GAMMA_DEG, abs=0.01)
    versions, _ = read_model_history(calibration)
    assert [v.writer for v in versions][-1] == 'inclino calibration restore 1'
    assert versions[1].text != versions[2].text and len(versions) == 3

    code, out, err = quiet(['calibration', 'diff', f'{calibration}@2', calibration])
    assert code == 0, err
    assert 'installation: changed' in out and 'gamma_deg: ' in out
    # The change at each attitude, computed here from the stages directly: the same raw
    # reading through each model's apply, inclination acos(z / |f|) (seed 000 Eq. 15).
    changes = re.findall(r': inclination ([+-][0-9.]+) deg', out)
    assert len(changes) == 5
    for (inclination_deg, toolface_deg), change in zip(
            ((1.0, 0.0), (5.0, 90.0), (30.0, 45.0), (60.0, 200.0), (90.0, 300.0)), changes):
        raw = tilted_reading(inclination_deg, toolface_deg)
        angle = [math.degrees(math.acos(f[2] / np.linalg.norm(f)))
                 for f in (m.apply(raw[None])[0] for m in (first, restored))]
        assert float(change) == pytest.approx(angle[1] - angle[0], abs=1e-4)
    code, _, err = quiet(['calibration', 'diff', calibration, f'{calibration}@9'])
    assert code == 2 and 'no version 9' in err


def test_a_damaged_history_never_blocks_the_file(tmp_path):
    """A version edited by hand, and a history that is a file: the file loads, it is reported."""
    calibration = str(tmp_path / 'cal.json')
    assert fit_level(level_csv(tmp_path / 'a.csv'), calibration)[0] == 0
    entry = os.path.join(history_folder(calibration), 'v000001.json')
    with open(entry) as stream:
        text = stream.read()
    with open(entry, 'w') as stream:
        stream.write(text.replace('gamma_deg', 'gamma_deX'))
    assert load_model(calibration).installation is not None
    code, out, err = quiet(['calibration', 'history', calibration])
    assert code == 0 and 'damaged: version 1' in err and 'does not match' in err
    assert fit_level(level_csv(tmp_path / 'b.csv'), calibration)[0] == 0  # writes go on
    versions, problems = read_model_history(calibration)
    # The damaged version 1 was the file: it is kept again, whole, before the new one.
    assert [v.number for v in versions] == [2, 3] and len(problems) == 1
    assert versions[0].writer.startswith('unknown')
    broken = str(tmp_path / 'other.json')
    save_model(broken, CalibrationModel(3))
    os.rename(history_folder(broken), str(tmp_path / 'moved'))
    with open(history_folder(broken), 'w') as stream:
        stream.write('not a folder')
    assert load_model(broken) == CalibrationModel(3)
    assert read_model_history(broken)[1][0].startswith('the history')


def test_the_history_keeps_the_newest_versions_and_says_which_it_removed(tmp_path):
    """Five fit-levels with --history-keep 2: versions 4 and 5 stay; each write names what went."""
    calibration = str(tmp_path / 'cal.json')
    notes = []
    for i in range(5):
        code, _, err = fit_level(level_csv(tmp_path / f'{i}.csv', gamma_deg=0.1 * i, seed=i),
                                 calibration, '--history-keep', 2)
        assert code == 0, err
        notes.append([line for line in err.splitlines() if 'removed' in line])
    assert notes[:2] == [[], []]
    assert notes[2:] == [[f'inclino fit-level: note: {calibration}: removed version {n} from its '
                          'history (it keeps the newest 2, and the version in use)']
                         for n in (1, 2, 3)]
    versions, problems = read_model_history(calibration)
    assert problems == [] and [v.number for v in versions] == [4, 5]
    assert versions[-1].sha256 == digest(open(calibration).read())
    assert load_model(calibration).installation.gamma_deg == pytest.approx(0.4, abs=0.01)
    # A restore keeps as many (restore 4: versions 5 and 6 stay, 6 holding 4's text).
    code, _, err = quiet(['calibration', 'restore', calibration, '4', '--history-keep', 2])
    assert code == 0 and 'removed version 4 from its history' in err
    versions, _ = read_model_history(calibration)
    assert [v.number for v in versions] == [5, 6]
    code, _, err = quiet(['calibration', 'restore', calibration, '6', '--history-keep', 0])
    assert code == 2 and "the range of the node's calibration.history_keep" in err


def test_the_default_keep_is_the_node_parameter_and_generous(tmp_path):
    """One definition: the node's calibration.history_keep default, what every write keeps."""
    (parameter,) = (p for p in PARAMETERS if p.name == 'calibration.history_keep')
    assert parameter.default == history.DEFAULT_KEEP == 200 and parameter.low == 1
    code, out, _ = quiet(['fit-level', '--help'])
    assert code == 0 and 'as calibration.history_keep' in ' '.join(out.split())
    calibration = str(tmp_path / 'cal.json')
    save_model(calibration, CalibrationModel(3, sensor_id='SN0'))
    first = os.path.join(history_folder(calibration), 'v000001.json')
    for number in range(2, history.DEFAULT_KEEP + 3):   # as if written 202 times
        shutil.copyfile(first, os.path.join(history_folder(calibration), f'v{number:06d}.json'))
    save_model(calibration, CalibrationModel(3, sensor_id='SN1'))
    versions, _ = read_model_history(calibration)
    assert [v.number for v in versions] == list(range(4, history.DEFAULT_KEEP + 4))


def test_pruning_never_removes_the_version_in_use_nor_the_newest(tmp_path):
    """The file holds version 2 (a write killed between history and file): 2 and 4 stay."""
    calibration = str(tmp_path / 'cal.json')
    for sensor in range(4):
        save_model(calibration, CalibrationModel(3, sensor_id=f'SN{sensor}'))
    versions, _ = read_model_history(calibration)
    with open(calibration, 'w') as stream:
        stream.write(versions[1].text)
    assert history.prune(calibration, 1) == [1, 3]
    assert [v.number for v in read_model_history(calibration)[0]] == [2, 4]
    assert history.prune(calibration, 1, in_use={versions[3].sha256}) == []
    assert load_model(calibration).sensor_id == 'SN1'


def test_the_node_prunes_with_its_parameter_and_logs_it(start_node, probe, tmp_path):
    """calibration.history_keep 1: three level captures leave the newest; the log names others."""
    node = start_node(**{'calibration.history_keep': 1, 'level_capture.samples': 100})
    probe.wait_for_node()
    level = tilted_reading(0.0, 0.0, GAMMA_DEG, BETA_DEG)
    rng = np.random.default_rng(3)
    for _ in range(3):
        response = probe.calibrate(lambda i: level + rng.normal(0.0, NOISE_MPS2, 3))
        assert response.success, response.message
    calibration = str(tmp_path / 'calibration.json')
    versions, problems = read_model_history(calibration)
    assert problems == [] and [v.number for v in versions] == [3]
    assert versions[0].sha256 == digest(open(calibration).read())
    log = node.log()
    assert f'{calibration}: removed version 1 from its history (it keeps the newest 1' in log
    assert f'{calibration}: removed version 2 from its history' in log


WRITER = """
import sys
from inclino_ros.calibration.model import CalibrationModel, Installation, save_model
path = sys.argv[1]
for i in range(100000):
    save_model(path, CalibrationModel(3, installation=Installation(
        gamma_deg=(i % 100) * 0.01, beta_deg=0.0, captured_at='2026-03-01T10:20:30+00:00',
        sample_count=10, std_deg=0.001, g_total_mps2=9.80665)), 'kill test')
    print(i, flush=True)
"""


def test_kill_9_during_writes_leaves_file_and_history_valid(tmp_path):
    """A writer killed at random points (30 times): the file and every version are valid."""
    calibration = str(tmp_path / 'cal.json')
    rng = random.Random(7)
    for _ in range(30):
        writer = subprocess.Popen([sys.executable, '-c', WRITER, calibration],
                                  stdout=subprocess.PIPE, text=True)
        assert writer.stdout.readline()  # one write done: the next ones are under way
        time.sleep(rng.uniform(0.0, 0.05))
        writer.send_signal(signal.SIGKILL)
        writer.wait()
        writer.stdout.close()
        model = load_model(calibration)
        versions, problems = read_model_history(calibration)
        assert problems == []
        assert model.installation is not None
        assert digest(open(calibration).read()) in {v.sha256 for v in versions}
    assert len(versions) >= 30


def test_a_fifo_as_calibration_or_input_is_refused_at_once(tmp_path):
    """A FIFO named as calibration file or input CSV: exit 2 with the reason, never a hang."""
    fifo = tmp_path / 'fifo'
    os.mkfifo(fifo)
    csv = level_csv(tmp_path / 'a.csv')
    for argv, named in ((['fit-level', csv, '--calibration', fifo], 'FIFO'),
                        (['fit-level', fifo, '--calibration', tmp_path / 'cal.json'], 'FIFO'),
                        (['calibration', 'history', fifo], 'FIFO')):
        result = subprocess.run([INCLINO, *map(str, argv)], capture_output=True, text=True,
                                timeout=60)
        assert result.returncode == 2 and named in result.stderr, result.stderr
    assert not (tmp_path / 'cal.json').exists()


def test_a_fifo_and_a_dangling_link_beside_the_output_change_nothing(tmp_path):
    """
    A FIFO and a dangling link beside the calibration file: written, and said so.

    Before, the whole folder was fsynced after the rename: a hang on the FIFO, and a
    refusal on the dangling link while the new file was already in place.
    """
    folder = tmp_path / 'job'
    folder.mkdir()
    os.mkfifo(folder / 'pipe')
    (folder / 'dangling').symlink_to(tmp_path / 'nowhere')
    calibration = folder / 'cal.json'
    result = subprocess.run(
        [INCLINO, 'fit-level', level_csv(tmp_path / 'a.csv'), '--calibration', str(calibration)],
        capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert f'{calibration}' in result.stdout
    assert load_model(str(calibration)).installation.gamma_deg == pytest.approx(
        GAMMA_DEG, abs=0.01)


def test_a_250_byte_name_has_a_history(tmp_path):
    """
    The longest names a file system takes are calibrations like any other (issue 21).

    ``NAME.history`` of a 250-byte NAME is 258 bytes, more than NAME_MAX (255):
    before, every write of such a file failed.  Its history folder now has a
    shortened name, the one ``calibration history`` and ``restore`` look in.
    """
    for name in ('c' * 245 + '.json', 'é' * 120 + 'abcdef.json'):   # 250 and 251 bytes
        calibration = str(tmp_path / name)
        assert len(os.fsencode(name)) >= 250
        assert fit_level(level_csv(tmp_path / 'a.csv'), calibration)[0] == 0
        assert fit_level(level_csv(tmp_path / 'b.csv', gamma_deg=-0.4), calibration)[0] == 0
        folder = history_folder(calibration)
        assert len(os.fsencode(os.path.basename(folder))) <= 255 and os.path.isdir(folder)
        code, out, err = quiet(['calibration', 'history', calibration])
        assert code == 0, err
        assert len([line for line in out.splitlines() if re.match(r'\s+\d+ ', line)]) == 2
        assert quiet(['calibration', 'restore', calibration, '1'])[0] == 0
        assert load_model(calibration).installation.gamma_deg == pytest.approx(
            GAMMA_DEG, abs=0.01)
    # Two long names alike in their first 240 bytes keep two histories.
    assert len({history_folder(str(tmp_path / ('c' * 245 + tail)))
                for tail in ('.json', '.jsox')}) == 2
