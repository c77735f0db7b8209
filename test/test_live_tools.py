"""
The live tools against the running node: play, calibrate, call, param, monitor.

Each tool runs as its own process (the ``inclino`` console script), as a user
starts it; the node is the real ``inclinometer_node``.  Ctrl-C is a real SIGINT
sent once the tool shows it is at work, SIGTERM what a script's ``kill`` sends.
"""

import os
import signal
import subprocess
import sys
import time

from inclino_ros.calibration.model import load_model
from inclino_ros.io import bag
import numpy as np
import pytest

INCLINO = os.path.join(os.path.dirname(sys.executable), 'inclino')


def start(*args, cwd):
    """Start ``inclino ARGS`` in ``cwd``; stdout and stderr piped (text)."""
    return subprocess.Popen([INCLINO, *map(str, args)], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def inclino(*args, cwd):
    """Run ``inclino ARGS`` to its end; return (exit code, stdout, stderr)."""
    done = subprocess.run([INCLINO, *map(str, args)], cwd=cwd, capture_output=True, text=True,
                          timeout=120)
    return done.returncode, done.stdout, done.stderr


def read_until(process, text, limit_chars=20_000):
    """
    Read the process's stderr until ``text`` appears (progress bars end lines with CR).

    A failsafe, not a timing: what a tool prints before ``text`` is short, so
    more than ``limit_chars`` (or the end of the stream) means it never comes.
    """
    seen = ''
    while text not in seen:
        char = process.stderr.read(1)
        if not char or len(seen) > limit_chars:
            process.kill()
            raise AssertionError(f'{text!r} never came: {seen[-2000:]}')
        seen += char
    return seen


def finish(process, sig=None):
    """Send ``sig`` (if any), wait; return (exit code, stdout, rest of stderr)."""
    if sig is not None:
        process.send_signal(sig)
    stdout, stderr = process.communicate(timeout=60)
    return process.returncode, stdout, stderr


@pytest.fixture
def bench(tmp_path):
    """Simulate the virtual bench into ``tmp_path``: a level segment of 3 s, 12 stations."""
    code, _, err = inclino('simulate', 'bench_bag', cwd=tmp_path)
    assert code == 0, err
    return tmp_path


def test_level_calibration_with_play_calibrate_monitor_param(start_node, probe, bench):
    """The README walkthrough: loop the level segment, calibrate, stop play, look, process."""
    start_node(**{'level_capture.samples': 600})
    # As a user does, who starts play once the node is up: play waits --wait-s (10 s) for
    # a subscriber of any node, which a node still starting on a loaded machine may pass.
    probe.wait_for_node()
    player = start('play', 'bench_bag', '--end-s', 3, '--loop', cwd=bench)
    read_until(player, 'playing 600 messages of /imu/data_raw')
    code, out, err = inclino('calibrate', cwd=bench)
    assert code == 0, err
    assert 'calibrated from 600 samples' in out
    assert out.rstrip().endswith('toolface_zero: board; toolface_zero_meaning: relative to the '
                                 'sensor board: its roll about the tool axis is not calibrated '
                                 '(no stand or high-side mark), and the toolface 1 sigma leaves '
                                 'that offset out')
    assert 'calibrate_level: collecting' in err          # the progress bar
    code, _, err = finish(player, signal.SIGTERM)        # what `kill` in a script sends
    assert code == 0 and 'stopped: published' in err and 'Traceback' not in err
    installation = load_model(bench / 'calibration.json').installation
    # The whole level segment, each of its 600 samples once (2e-3 m/s^2 noise): 0.0005 deg 1 sigma.
    assert installation.gamma_deg == pytest.approx(0.8, abs=0.003)
    assert installation.beta_deg == pytest.approx(-1.2, abs=0.003)

    code, out, err = inclino('monitor', '--count', 1, '--period-s', 1.5, cwd=bench)
    assert code == 0, err
    assert 'calibration   installation' in out
    assert 'last answer of calibrate_level: succeeded: calibrated from 600 samples' in out
    assert 'OK    calibration: calibrated: installation; toolface zero: board' in out
    assert 'toolface zero board: relative to the sensor board' in out

    assert inclino('param', 'get', 'level_capture.samples', cwd=bench)[1] == '600\n'
    assert inclino('param', 'set', 'stand.toolface_deg', '270', cwd=bench)[:2] == (
        0, 'stand.toolface_deg: 270.0\n')
    code, _, err = inclino('param', 'set', 'stand.toolface_deg', '400', cwd=bench)
    assert code == 1 and 'out of range' in err
    code, _, err = inclino('param', 'set', 'accelerometer_axes', '2', cwd=bench)
    assert code == 1 and 'read-only' in err
    code, _, err = inclino('param', 'get', 'no.such', cwd=bench)
    assert code == 2 and 'no parameter' in err
    code, out, _ = inclino('param', 'list', cwd=bench)
    assert code == 0 and "accelerometer_axes_map: '+X+Y+Z'  (read-only)" in out
    assert 'stand.toolface_deg: 270.0\n' in out

    code, _, err = inclino('process', 'bench_bag', 'corrected_bag', '--calibration',
                           'calibration.json', cwd=bench)
    assert code == 0, err
    code, out, err = inclino('compare', 'corrected_bag', 'bench_bag', '--max-error-deg', 0.01,
                             cwd=bench)
    assert code == 0, out + err
    assert 'worst station mean error: inclination 0.00' in out


def test_monitor_counts_its_views_from_the_first_survey(start_node, probe, bench):
    """
    A monitor started beside play counts the views of play's input, however late it comes.

    The walkthrough's `monitor --count 4` printed four views before a play started on a
    loaded host had reached the node: none showed an angle (CI, stop 28).
    """
    start_node()
    probe.wait_for_node()
    monitor = start('monitor', '--count', 1, '--period-s', 0.5, '--wait-s', 60, cwd=bench)
    first_view = ''
    while 'angles        no survey yet' not in first_view:   # the node has no input yet
        line = monitor.stdout.readline()
        assert line, f'the monitor ended before its first view: {finish(monitor)}'
        first_view += line
    player = start('play', 'bench_bag', '--start-s', 3, cwd=bench)
    code, out, err = finish(monitor)
    finish(player, signal.SIGTERM)
    assert code == 0, err
    views = (first_view + out).split('\n\n')
    assert 'angles        inclination' in views[-2], views   # the last view (then a blank)
    assert all('angles        no survey yet' in view for view in views[:-2])


def sensor_bag(path):
    """Write 200 Imu, 200 MagneticField (0.5 ms later) and 5 Temperature messages (1 s)."""
    stamps = 1_000_000_000 + np.arange(200) * 5_000_000
    g = np.tile([3.0, 4.0, np.sqrt(9.80665 ** 2 - 25.0)], (200, 1))
    field = np.tile([20000.0, 1000.0, -40000.0], (200, 1))
    with bag.BagWriter(path) as writer:
        for topic, msgtype in (('/imu/data_raw', bag.IMU), ('/imu/mag', bag.MAGNETIC_FIELD),
                               ('/imu/temperature', bag.TEMPERATURE)):
            writer.add_topic(topic, msgtype)
        writer.write_series({'/imu/data_raw': bag.raw_imu(stamps, 'imu', g, 0.01)})
        writer.write_series({'/imu/mag': bag.magnetometer(stamps + 500_000, 'mag', field, 5.0)})
        writer.write_series({'/imu/temperature': bag.TemperatureSeries(
            stamps[::40], np.full(5, 't'), np.arange(5) + 30.0, np.zeros(5))})


def test_play_replays_every_sensor_topic_with_its_stamps(start_node, probe, tmp_path):
    """Imu, MagneticField and Temperature all reach the node, in stamp order, stamps kept."""
    sensor_bag(tmp_path / 'sensors')
    start_node()
    probe.wait_for_node()
    code, out, err = inclino('play', 'sensors', '--rate', 2, cwd=tmp_path)
    assert code == 0, err
    assert 'published 405 messages on /imu/data_raw, /imu/mag, /imu/temperature' in out
    surveys = probe.wait_outputs('survey', 200)
    stamps = [s.header.stamp.sec * 10 ** 9 + s.header.stamp.nanosec for s in surveys]
    assert stamps == (1_000_000_000 + np.arange(200) * 5_000_000).tolist()
    # Every sample after the first magnetometer reading has an azimuth.
    assert len(probe.wait_outputs('azimuth', 199)) == 199
    _, values = probe.wait_status(': temperature')
    assert values['temperature_c'] == '34.00'


def test_play_into_a_node_just_started_loses_nothing(start_node, probe, tmp_path):
    """
    Play started with the node: every message reaches it (accepted_total, its diagnostics).

    The node's best-effort subscription drops what comes from a publisher it has not
    matched yet, and play's publisher may see the subscription first: play waits until
    the node has heard it (``LiveSession.wait_heard_by``) before the first message.
    """
    sensor_bag(tmp_path / 'sensors')
    start_node()
    code, out, err = inclino('play', 'sensors', '--topics', '/imu/data_raw', '--rate', 4,
                             cwd=tmp_path)
    assert code == 0, err
    assert 'published 200 messages on /imu/data_raw' in out
    totals = []

    def all_accepted():
        totals[:] = [int(values['accepted_total']) for values in probe.status_values(': input')]
        return 200 in totals

    try:
        probe.spin_until(all_accepted, 30.0)
    except AssertionError:
        raise AssertionError(f'the node accepted {totals[-1:]} of 200 messages') from None


def test_ctrl_c_never_prints_a_traceback(start_node, probe, bench):
    """Ctrl-C in play (stops, says how far), calibrate and call (say what goes on): clean."""
    start_node(**{'level_capture.timeout_s': 2.0, 'survey.timeout_s': 60.0})
    probe.wait_for_node()
    progress = probe.listen_latched('/inclinometer/capture_progress')
    player = start('play', 'bench_bag', '--loop', cwd=bench)
    read_until(player, 'playing')
    code, _, err = finish(player, signal.SIGINT)
    assert code == 0 and 'Traceback' not in err
    assert 'inclino play: stopped: published' in err and 'of 5400 messages' in err
    for command in (('calibrate',), ('call', 'take_survey')):
        caller = start(*command, cwd=bench)
        read_until(caller, 'collecting')      # no samples come: the capture waits
        code, out, err = finish(caller, signal.SIGINT)
        assert code == 130 and 'Traceback' not in err, err
        assert 'interrupted: no answer' in err
        if command == ('calibrate',):   # its capture runs on to its 2 s timeout: wait
            probe.spin_until(lambda: progress and progress[-1]['state'] == 'refused')


def test_tools_say_what_to_check_when_no_node_answers(tmp_path):
    """No node: calibrate, call, param and play give up after --wait-s, naming the settings."""
    sensor_bag(tmp_path / 'sensors')
    for command in (('calibrate',), ('call', 'solve_msa'), ('param', 'list'),
                    ('play', 'sensors')):
        code, _, err = inclino(*command, '--wait-s', 0.5, cwd=tmp_path)
        assert code == 2, (command, err)
        assert f'ROS_DOMAIN_ID (this shell: {os.environ["ROS_DOMAIN_ID"]})' in err, err
        assert 'Traceback' not in err


def test_call_shows_a_timed_capture_and_the_answer(start_node, bench):
    """A rotation capture without magnetometer: the seconds go by, then the refusal (exit 1)."""
    start_node(**{'rotation.duration_s': 1.0})
    player = start('play', 'bench_bag', '--loop', cwd=bench)
    read_until(player, 'playing')
    code, out, err = inclino('call', 'capture_rotation', cwd=bench)
    finish(player, signal.SIGINT)
    assert code == 1 and out.startswith('refused:'), out + err
    assert 'capture_rotation: collecting' in err and ' s left' in err


#: Concurrent callers of the stress test: before the discovery handshake (LiveSession.
#: wait_heard_by), 3 to 7 of 40 lost their request or answer on a loaded 2-core host, and a
#: caller whose answer was lost waited for ever.
CALLERS = 40
#: --wait-s of each caller.
STRESS_WAIT_S = 20.0
#: Seconds 40 Python processes importing rclpy take to start on a loaded 2-core host (measured
#: up to 60 s at load 40): the one part of a caller's time that is not its own bound.
STARTUP_S = 90.0


def test_concurrent_calls_each_end_with_the_answer_or_a_clear_error(start_node, probe, tmp_path):
    """
    40 ``inclino call`` at once against one node: each ends, answered, within its bound.

    Half call clear_positions (resent while unanswered: doing it twice is doing
    it once), half solve_msa, refused at once without a reference field and
    sent exactly once (a service that may change the calibration is never
    resent).  Each caller ends within its documented bound (3 x --wait-s plus
    the teardown's TEARDOWN_S, after its start-up) with the node's answer or
    the clear "no answer ... may or may not have been applied" (exit 3);
    every clear_positions is answered, and the node took each solve_msa
    request at most once.  (Measured at load 30-40: 40 of 40 answered in
    most runs, at worst 2 solve_msa requests of 20 never reached the node and
    said so; before the handshake 3-7 of 40 were lost and those callers
    never ended.)
    """
    from inclino_ros.cli.live import TEARDOWN_S

    node = start_node()
    probe.wait_for_node()
    services = ['clear_positions', 'solve_msa'] * (CALLERS // 2)
    callers = [start('call', service, '--wait-s', STRESS_WAIT_S, cwd=tmp_path)
               for service in services]
    end = time.monotonic() + STARTUP_S + 3 * STRESS_WAIT_S + TEARDOWN_S
    while any(caller.poll() is None for caller in callers) and time.monotonic() < end:
        time.sleep(0.2)   # a check, not a timing: until every caller ended, or the bound
    hung = sum(caller.poll() is None for caller in callers)
    for caller in callers:
        if caller.poll() is None:
            caller.kill()
    results = [(caller.returncode, *caller.communicate()) for caller in callers]
    assert hung == 0, f'{hung} of {CALLERS} callers never ended'
    no_answer = 'the request may or may not have been applied; check with'
    for service, (code, out, err) in zip(services, results):
        assert 'Traceback' not in err, err
        if code == 3:
            assert no_answer in err, err
        elif service == 'clear_positions':
            assert (code, out) == (0, 'cleared 0 stand positions\n'), (code, out, err)
        else:
            assert code == 1 and out.startswith('refused: MSA needs the reference field'), (
                code, out, err)
    # clear_positions is sent again until answered: none may be left without its answer.
    assert all(code == 0 for service, (code, _, _) in zip(services, results)
               if service == 'clear_positions')
    # solve_msa is sent once: the node took each request at most once, every answered one.
    refused = sum(code == 1 for code, _, _ in results)
    probe.spin_until(lambda: node.log().count('MSA needs the reference field') >= refused)
    assert refused <= node.log().count('MSA needs the reference field') <= CALLERS // 2
