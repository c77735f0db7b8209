"""
Issue 10 on the command line: nothing lost, nothing absurd accepted, no crash, no hang.

Each test is a case the issue found: before, the command exited 0 having overwritten its
input, stored an absurd calibration, skipped data or accepted a NaN option, or it ended in
a traceback, a hang or gigabytes of memory.  Every error is now one line on stderr (exit
2 unusable, 1 refused, 130 Ctrl-C) and leaves no output and no temporary behind.
"""

import fcntl
import math
import os
import re
import resource
import signal
import subprocess
import sys

from hypothesis import given, HealthCheck, settings, strategies as st
from inclino_ros.calibration.level_capture import LevelLimits, solve_level_capture
from inclino_ros.calibration.model import CalibrationModel, save_model
from inclino_ros.cli.main import main as inclino
from inclino_ros.io import bag
import numpy as np
import pytest
from ros_harness import installed_script
from test_msa_cli import quiet, REFERENCE_ARGS

G = 9.80665
INCLINO = installed_script('inclino')


def summary_values(stdout):
    """Return the ``name: value`` lines of a process summary as a dict of strings."""
    return dict(line.split(': ', 1) for line in stdout.splitlines() if ': ' in line)


def leftovers(folder):
    """Return the temporaries (``.NAME-PID-X.tmp``) left in ``folder``."""
    return [name for name in os.listdir(folder) if name.endswith('.tmp')]


def file_bytes(path):
    """Return the content of ``path``."""
    with open(path, 'rb') as stream:
        return stream.read()


@pytest.fixture(scope='module')
def bench(tmp_path_factory):
    """Return (work folder, bag of ~10 000 samples in several mcap chunks, calibration)."""
    work = tmp_path_factory.mktemp('bench')
    sim, calibration = str(work / 'sim'), str(work / 'cal.json')
    code, _, err = quiet(['simulate', sim, '--rate-hz', 1000, '--level-s', 1, '--station-s', 0.75])
    assert code == 0, err
    raw = bag.concatenate(bag.read(sim, '/imu/data_raw'))
    level = raw.linear_acceleration_mps2[:1000]
    save_model(calibration, CalibrationModel(3, installation=solve_level_capture(
        level, 3, LevelLimits(5.0, G, 0.05))))
    return work, sim, calibration


# --- data loss --------------------------------------------------------------------------

@pytest.mark.parametrize('spelling', ['same name', 'symlink', 'hard link'])
def test_msa_never_writes_over_its_input(tmp_path, spelling):
    """An ``msa IN.csv -o IN.csv`` replaced the station readings (exit 0); now exit 2, IN kept."""
    stations = tmp_path / 'stations.csv'
    assert quiet(['simulate-well', stations])[0] == 0
    before = file_bytes(stations)
    output = {'same name': stations, 'symlink': tmp_path / 'link.csv',
              'hard link': tmp_path / 'hard.csv'}[spelling]
    if spelling == 'symlink':
        output.symlink_to(stations)
    elif spelling == 'hard link':
        os.link(stations, output)
    for force in ([], ['--force']):
        code, out, err = quiet(['msa', stations, '-o', output, *REFERENCE_ARGS, *force])
        assert code == 2 and 'is the input' in err and 'Traceback' not in err
        assert file_bytes(stations) == before
    assert not (tmp_path / f'{output.name}.msa.json').exists() and not leftovers(tmp_path)


def test_existing_outputs_are_refused_unless_forced(tmp_path):
    """An existing msa -o, OUT.msa.json, --report or simulate-well CSV is kept without --force."""
    stations, out = tmp_path / 'stations.csv', tmp_path / 'out.csv'
    assert quiet(['simulate-well', stations])[0] == 0
    code, _, err = quiet(['simulate-well', stations, '--stations', 5])
    assert code == 2 and 'exists already' in err and 'force' in err
    assert file_bytes(stations).count(b'\n') == 31
    for existing in (out, tmp_path / 'out.csv.msa.json', tmp_path / 'r.png'):
        existing.write_text('mine')
        code, _, err = quiet(['msa', stations, '-o', out, *REFERENCE_ARGS,
                              '--report', tmp_path / 'r.png'])
        assert code == 2 and f'{existing} exists already' in err
        assert existing.read_text() == 'mine'
        existing.unlink()
    out.write_text('mine')
    code, _, err = quiet(['msa', stations, '-o', out, *REFERENCE_ARGS, '--force'])
    assert code == 0, err
    assert out.read_text().startswith('md,inclination_deg')
    assert quiet(['simulate-well', stations, '--stations', 5, '--force'])[0] == 0
    assert file_bytes(stations).count(b'\n') == 6
    assert not leftovers(tmp_path)


def test_simulate_onto_an_existing_bag(tmp_path):
    """A traceback ("exists already" from rosbags) before; now a message, the bag kept."""
    sim = tmp_path / 'sim'
    assert quiet(['simulate', sim, '--level-s', 0.1, '--station-s', 0.1])[0] == 0
    before = sorted(os.listdir(sim))
    code, out, err = quiet(['simulate', sim])
    assert code == 2 and 'exists already' in err and out == ''
    assert sorted(os.listdir(sim)) == before
    assert quiet(['simulate', sim, '--force', '--level-s', 0.1, '--station-s', 0.1])[0] == 0
    assert not leftovers(tmp_path)


def test_a_failed_process_leaves_no_output_and_the_rerun_works(bench, tmp_path):
    """A write failing half-way (disk full) left a bag that blocked the rerun; now none."""
    _, sim, calibration = bench
    out = tmp_path / 'out'
    original = bag.BagWriter.write
    calls = []

    def fill_disk(self, *args):
        calls.append(1)
        if len(calls) == 1:
            raise OSError(28, 'No space left on device')
        return original(self, *args)

    bag.BagWriter.write = fill_disk
    try:
        code, out_text, err = quiet(['process', sim, out, '--calibration', calibration])
    finally:
        bag.BagWriter.write = original
    assert code == 2 and 'No space left on device' in err and 'Traceback' not in err
    assert not out.exists() and not leftovers(tmp_path)
    code, _, err = quiet(['process', sim, out, '--calibration', calibration])
    assert code == 0, err


def test_process_on_a_read_only_place(bench):
    """An output that cannot be created is one line, exit 2."""
    _, sim, calibration = bench
    code, _, err = quiet(['process', sim, '/proc/inclino_out', '--calibration', calibration])
    assert code == 2 and err.count('\n') == 1 and 'inclino process: error:' in err


def test_stale_temporaries_of_a_killed_run_are_removed(bench, tmp_path):
    """A kill -9 leaves ``.out-PID-X.tmp``; the next run of the same OUT removes it."""
    _, sim, calibration = bench
    child = subprocess.Popen([sys.executable, '-c', 'pass'])
    child.wait()
    stale = tmp_path / f'.out-{child.pid}-0123abcd.tmp'
    stale.mkdir()
    (stale / 'bag_0.mcap').write_bytes(b'half')
    assert quiet(['process', sim, tmp_path / 'out', '--calibration', calibration])[0] == 0
    assert sorted(os.listdir(tmp_path)) == ['out']


# --- absurd calibrations ----------------------------------------------------------------

def rotation_csv(path, radius_nT=20000.0, axial_nT=40000.0, scale=1.0):
    """Write a full rotation (bx, by, bz) of 72 readings; return its path."""
    angle = np.radians(np.arange(0.0, 360.0, 5.0))
    rows = np.column_stack([80.0 + radius_nT * np.cos(angle), -80.0 + radius_nT * np.sin(angle),
                            np.full(angle.size, axial_nT)]) * scale
    np.savetxt(path, rows, delimiter=',', header='bx,by,bz', comments='')
    return path


@pytest.mark.parametrize('case,kwargs,named', [
    ('tesla', {'scale': 1e-9}, 'is it in tesla?'),
    ('radius 1e120', {'radius_nT': 1e120}, 'not an Earth field'),
    ('2e6 nT', {'radius_nT': 2e6, 'axial_nT': 0.0}, 'not an Earth field'),
    ('dead', {'scale': 0.0}, 'dead magnetometer'),
])
def test_fit_rotation_refuses_readings_no_magnetometer_gives(tmp_path, case, kwargs, named):
    """Tesla stored a hard iron of 8e-8 nT, 1e120 one of 1e104 nT (exit 0); now exit 1."""
    calibration = tmp_path / 'cal.json'
    save_model(calibration, CalibrationModel(3))
    before = file_bytes(calibration)
    assert quiet(['fit-rotation', rotation_csv(tmp_path / 'ok.csv'), '--calibration',
                  tmp_path / 'ok.json'])[0] == 0
    code, _, err = quiet(['fit-rotation', rotation_csv(tmp_path / 'r.csv', **kwargs),
                          '--calibration', calibration])
    assert code == 1 and named in err and 'left unchanged' in err
    assert file_bytes(calibration) == before


def stand_csv(path, scale=1.0, extra=None):
    """Write 24 readings of a still, ideal sensor in many attitudes; return its path."""
    rng = np.random.default_rng(3)
    v = rng.normal(size=(24, 3))
    rows = G * v / np.linalg.norm(v, axis=1)[:, None] * scale
    if extra is not None:
        rows = np.vstack([rows, extra])
    np.savetxt(path, rows, delimiter=',', header='ax,ay,az', comments='')
    return path


@pytest.mark.parametrize('huge', [[1e200, 0.0, 0.0], [1e300, 1e300, 1e300]])
def test_fit_stand_sphere_with_a_huge_reading_ends(tmp_path, huge):
    """
    One huge reading spun at 100 % CPU forever (1e200) or ended in a LinAlgError traceback.

    Now refused at once; the wait is bounded by a timeout.
    """
    csv_path = stand_csv(tmp_path / 's.csv', extra=[huge])
    result = subprocess.run([INCLINO, 'fit-stand', str(csv_path), '--method', 'sphere',
                             '--calibration', str(tmp_path / 'cal.json')],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 1, result.stderr
    assert 'beyond 2 g' in result.stderr and 'Traceback' not in result.stderr
    assert not (tmp_path / 'cal.json').exists()


def test_fit_stand_in_g_names_the_unit(tmp_path):
    """Readings in g instead of m/s^2: refused, the unit named."""
    code, _, err = quiet(['fit-stand', stand_csv(tmp_path / 's.csv', scale=1.0 / G),
                          '--method', 'sphere', '--calibration', tmp_path / 'cal.json'])
    assert code == 1 and 'is it in g?' in err
    assert quiet(['fit-stand', stand_csv(tmp_path / 'ok.csv'), '--method', 'sphere',
                  '--calibration', tmp_path / 'ok.json'])[0] == 0


def test_a_hand_edited_calibration_is_refused_by_process(bench, tmp_path):
    """A stand bias of 1e300 gave 89.2 deg on every output; now exit 2 naming the field."""
    _, sim, calibration = bench
    edited = tmp_path / 'cal.json'
    edited.write_text(open(calibration).read().replace(
        '"accelerometer_axes": 3', '"accelerometer_axes": 3, "stand": {"scale_matrix": '
        '[[1, 0, 0], [0, 1, 0], [0, 0, 1]], "bias_mps2": [1e300, 0, 0], "method": "stand", '
        '"condition_number": 1.0, "rms_inclination_deg": 0.0, "positions": 9, '
        '"fitted_at": "2026-03-01T10:20:30+00:00", "temperature_c": null, '
        '"scale_coefficients": null, "bias_coefficients_mps2": null, "t_min_c": null, '
        '"t_max_c": null, "parameter_covariance": null}'))
    code, _, err = quiet(['process', sim, tmp_path / 'out', '--calibration', edited])
    assert code == 2 and 'stand.bias_mps2' in err
    assert not (tmp_path / 'out').exists()


# --- corrupt bags -----------------------------------------------------------------------

@settings(max_examples=25, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(where=st.floats(0.0, 1.0), data=st.binary(min_size=1, max_size=64))
def test_a_corrupted_bag_is_read_whole_or_refused(bench, tmp_path_factory, where, data):
    """
    Random bytes written into a valid mcap: exit 0 with every message, or exit 2 and no OUT.

    Before, 6 of 90 runs exited 0 having skipped whole chunks (up to 41 % of the samples)
    and 14 ended in a traceback (OverflowError, Truncated record).
    """
    work, sim, calibration = bench
    tmp = tmp_path_factory.mktemp('corrupt')
    damaged = tmp / 'sim'
    damaged.mkdir()
    for name in os.listdir(sim):
        (damaged / name).write_bytes(file_bytes(os.path.join(sim, name)))
    mcap = next(damaged.glob('*.mcap'))
    content = bytearray(mcap.read_bytes())
    offset = min(int(where * len(content)), len(content) - len(data))
    content[offset:offset + len(data)] = data
    mcap.write_bytes(bytes(content))
    count = bag.topic_info(sim, '/imu/data_raw')[1]
    code, out, err = quiet(['process', damaged, tmp / 'out', '--calibration', calibration])
    assert 'Traceback' not in err
    if code == 0:
        assert summary_values(out)['samples_in'] == str(count)
        assert bag.topic_info(str(tmp / 'out'), '/survey')[1] == int(
            summary_values(out)['accepted'])
    else:
        # One line after the progress bar.
        assert code == 2 and err.splitlines()[-1].startswith('inclino process: error: ')
        assert err.count('error:') == 1
        assert not (tmp / 'out').exists() and not leftovers(tmp)


def test_negative_stamps_are_a_message(tmp_path, bench):
    """Header stamps before 1970 ended in a traceback; now exit 2, one line, no OUT."""
    _, _, calibration = bench
    series = bag.raw_imu(np.arange(-5, 5) * 1_000_000, 'imu', np.tile([0.0, 0.0, G], (10, 1)),
                         0.01)
    source = tmp_path / 'in'
    os.mkdir(source)
    # A bag's log time cannot be negative: the stamps live in the header only.
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import get_typestore, Stores
    typestore = get_typestore(Stores.ROS2_JAZZY)
    os.rmdir(source)
    with Writer(source, version=9) as writer:
        connection = writer.add_connection('/imu/data_raw', bag.IMU, typestore=typestore)
        for i, data in enumerate(bag.encode(series)):
            writer.write(connection, i, data)
    code, _, err = quiet(['process', source, tmp_path / 'out', '--calibration', calibration])
    assert code == 2 and 'before 1970' in err.splitlines()[-1] and err.count('error:') == 1
    assert not (tmp_path / 'out').exists()


# --- options ----------------------------------------------------------------------------

@pytest.mark.parametrize('option,value', [
    ('--gravity-mps2', '0'), ('--gravity-mps2', 'nan'), ('--gravity-mps2', '-9.8'),
    ('--range-mps2', 'nan'), ('--range-mps2', 'inf'), ('--noise-mps2', 'nan'),
    ('--chunk-size', '0'), ('--max-pairing-s', '-1'), ('--reference-total-nT', 'inf'),
    ('--output-rate-hz', '1e-12'), ('--output-rate-hz', '1e-300')])
def test_process_options_are_checked(bench, tmp_path, option, value):
    """0, NaN or negative g turned the zero check off, NaN range let 1e300 through; now exit 2."""
    _, sim, calibration = bench
    code, out, err = quiet(['process', sim, tmp_path / 'out', '--calibration', calibration,
                            option, value])
    assert code == 2 and option in err and out == ''
    assert not (tmp_path / 'out').exists()


@pytest.mark.parametrize('argv,named', [
    (['msa', 'S', '-o', 'o.csv', *REFERENCE_ARGS, '--report', 'x.txt'], 'a report is a figure'),
    (['simulate-well', 'w.csv', '--stations', '100000000'], '--stations'),
    (['simulate-well', 'w.csv', '--reference-total-nT', 'nan'], '--reference-total-nT'),
    (['simulate', 'b', '--rate-hz', 'nan'], '--rate-hz'),
    (['simulate', 'b', '--seed', '-1'], '--seed'),
    (['simulate', 'b', '--rate-hz', '100000', '--station-s', '86400'], 'at most 1000000'),
    (['fit-stand', 'x.csv', '--calibration', 'c.json', '--max-rms-deg', 'nan'],
     '--max-rms-deg'),
    (['fit-temperature', 'x.csv', '--calibration', 'c.json', '--order', '0'], '--order'),
    (['fit-rotation', 'x.csv', '--calibration', 'c.json', '--start-s', 'inf'], '--start-s'),
    (['msa', 'S', '-o', 'o.csv', '--site', '95', '0', '0', '2026-01-01'], 'no site'),
])
def test_every_option_is_checked(tmp_path, monkeypatch, argv, named):
    """Each of these ran (NaN in, absurd out), took 24 GB or ended in a traceback."""
    monkeypatch.chdir(tmp_path)
    stations = tmp_path / 'S'
    assert quiet(['simulate-well', stations])[0] == 0
    code, out, err = quiet(argv)
    assert code == 2 and named in err and 'Traceback' not in err, err
    assert sorted(os.listdir(tmp_path)) == ['S', 'S.truth.json']


@pytest.mark.parametrize('argv,named', [
    (['play', 'bag', '--rate', '0'], '--rate'),
    (['play', 'bag', '--rate', 'nan'], '--rate'),
    (['play', 'bag', '--start-s', '-1'], '--start-s'),
    (['play', 'bag', '--end-s', 'inf'], '--end-s'),
    (['play', 'bag', '--wait-s', 'nan'], '--wait-s'),
    (['calibrate', '--wait-s', '-5'], '--wait-s'),
    (['call', 'calibrate_level', '--wait-s', 'inf'], '--wait-s'),
    (['monitor', '--period-s', '0'], '--period-s'),
    (['monitor', '--count', '0'], '--count'),
    (['play', 'bag', '--rate', '1e-300'], '--rate'),
    (['play', 'bag', '--wait-s', '1e308'], '--wait-s'),
    (['monitor', '--period-s', '1e308'], '--period-s'),
    (['call', 'calibrate_level', '--wait-s', '1e308'], '--wait-s'),
])
def test_live_tool_options_are_checked(argv, named):
    """The live tools' times and rates: a usage error naming the option, before any ROS."""
    code, out, err = quiet(argv)
    assert code == 2 and named in err and 'Traceback' not in err, err


def test_simulate_well_of_1e8_stations_needs_no_memory(tmp_path):
    """--stations 1e8 took 24 GB and was killed; now refused at once within 1 GB."""
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))

    result = subprocess.run([INCLINO, 'simulate-well', str(tmp_path / 'w.csv'), '--stations',
                             '100000000'], capture_output=True, text=True, timeout=120,
                            preexec_fn=limit)
    assert result.returncode == 2 and '--stations' in result.stderr
    assert 'Traceback' not in result.stderr and not (tmp_path / 'w.csv').exists()


# --- errors are messages ----------------------------------------------------------------

def test_an_unexpected_error_is_one_line_and_debug_shows_it(tmp_path, monkeypatch):
    """Anything unforeseen: one line and exit 1; with --debug the traceback."""
    from inclino_ros.cli import simulate_well

    def broken(*args):
        raise ZeroDivisionError('a bug')

    monkeypatch.setattr(simulate_well, 'simulate_well', broken)
    code, _, err = quiet(['simulate-well', tmp_path / 'w.csv'])
    assert code == 1 and err.count('\n') == 1
    assert 'unexpected ZeroDivisionError: a bug' in err and '--debug' in err
    with pytest.raises(ZeroDivisionError):
        inclino(['--debug', 'simulate-well', str(tmp_path / 'w.csv')])
    assert not leftovers(tmp_path) and not (tmp_path / 'w.csv').exists()


#: A tqdm bar's count: ``  12%|#2        | 60000/500000 [``.
PROGRESS = re.compile(rb'(\d+)/(\d+) \[')


def test_ctrl_c_in_process_stops_cleanly(bench, tmp_path):
    """SIGINT while processing: exit 130, what was done, no traceback, no OUT, no temporary."""
    work, sim, calibration = bench
    big = tmp_path / 'big'
    assert quiet(['simulate', big, '--rate-hz', 2000, '--level-s', 10, '--station-s', 20])[0] == 0
    child = subprocess.Popen([INCLINO, 'process', str(big), str(tmp_path / 'out'),
                              '--calibration', calibration, '--chunk-size', '100'],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    # It cannot run away while this test is not scheduled: its progress bar (~100 bytes
    # at most every 0.1 s of its work) fills a one-page pipe in ~4 s of its ~12 s of work,
    # then it waits for this test to read.  Wait (no timing) for the bar and a written
    # chunk of OUT, then freeze it (SIGSTOP) and prove it is still within the replay: not
    # ended, its bar short of the total.  SIGINT is sent to the frozen process: it is
    # interrupted right there (on a loaded machine it had finished before SIGINT came).
    fcntl.fcntl(child.stderr.fileno(), fcntl.F_SETPIPE_SZ, 4096)
    err = b''
    while not (PROGRESS.search(err) and any(
            os.path.getsize(os.path.join(root, name)) > 1 << 20  # a written chunk
            for root, _, names in os.walk(tmp_path) if '.tmp' in root for name in names)):
        chunk = os.read(child.stderr.fileno(), 4096)
        assert chunk, f'it ended before the output was written: {err[-2000:]!r}'
        err += chunk
    child.send_signal(signal.SIGSTOP)
    os.set_blocking(child.stderr.fileno(), False)
    try:
        err += os.read(child.stderr.fileno(), 1 << 20) or b''   # all it wrote until frozen
    except BlockingIOError:
        pass
    os.set_blocking(child.stderr.fileno(), True)
    frozen, total = map(int, PROGRESS.findall(err)[-1])
    assert child.poll() is None and frozen < total == 500_000, err[-2000:]
    assert leftovers(tmp_path)
    child.send_signal(signal.SIGINT)
    child.send_signal(signal.SIGCONT)
    _, rest = child.communicate(timeout=60)
    err = (err + rest).decode()
    assert child.returncode == 130, err
    assert 'Traceback' not in err
    done = int(re.search(r'interrupted \(Ctrl-C\) after (\d+) of 500000 messages', err).group(1))
    assert frozen <= done < total
    assert sorted(os.listdir(tmp_path)) == ['big', 'big.truth.json']


#: Run argv[1:], then print its peak resident set [KiB] and exit with its code.
PEAK_OF_CHILD = ('import resource, subprocess, sys; code = subprocess.call(sys.argv[1:]); '
                 'print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); sys.exit(code)')


def test_a_huge_frame_id_is_processed_in_bounded_memory(tmp_path, bench):
    """1000 messages with a 100 KB frame_id took 1.4 GB in process; now a few hundred MB."""
    _, _, calibration = bench
    frame_id = 'f' * 100_000
    source = str(tmp_path / 'in')
    with bag.BagWriter(source) as writer:
        writer.add_topic('/imu/data_raw', bag.IMU)
        for start in range(0, 1000, 100):
            writer.write_series({'/imu/data_raw': bag.raw_imu(
                1_000_000_000 + np.arange(start, start + 100) * 1_000_000, frame_id,
                np.tile([0.0, 0.0, G], (100, 1)), 0.01)})
    # The peak of the command alone, through a small parent: a child forked by this test
    # process counts this process's resident pages (930 MB late in a full suite) as its own.
    result = subprocess.run(
        [sys.executable, '-c', PEAK_OF_CHILD, INCLINO, 'process', source, str(tmp_path / 'out'),
         '--calibration', calibration], capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    peak_mb = int(result.stdout.split()[-1]) / 1024.0
    assert peak_mb < 600.0, f'{peak_mb:.0f} MB'
    survey = bag.concatenate(bag.read(str(tmp_path / 'out'), '/survey'))
    assert survey.stamps_ns.size == 1000 and set(survey.frame_ids.tolist()) == {frame_id}
    assert math.isfinite(survey.vector[0, 0])
