"""
Every refusal is a message that names the cause (issue 21, "unclear messages").

Each case below printed "unexpected SystemError", an AttributeError, an
argparse misreading, "refused: refused:", a help text naming an option that
does not exist, a traceback-like Python error, or left an empty output.
"""

import contextlib
import io
import os
import subprocess
import sys

from inclino_ros.cli import main as cli_main, param
from inclino_ros.cli.main import build_parser, main as inclino
from inclino_ros.cli.monitor import progress_text
from inclino_ros.cli.reference import site_reference
from inclino_ros.io import bag
import pytest
from test_msa_cli import quiet
from test_reliability_cli import bench  # noqa: F401 (a fixture)
from test_survey_cli import write_rows
from test_survey_refusals import calibration, HEADER, numbered, shots


def test_a_huge_integer_parameter_value_is_named():
    """The command param set level_capture.samples 1e23 (digits) was 'unexpected SystemError'."""
    with pytest.raises(ValueError, match='beyond a 64-bit integer'):
        param.parse_value('99999999999999999999999', 500)
    assert param.parse_value(str(2 ** 63 - 1), 500) == 2 ** 63 - 1


@pytest.mark.parametrize('value', ['-1e-3', '-2.5E+4', '-inf', '-.5', '-7'])
def test_a_negative_parameter_value_is_a_value_not_an_option(value):
    """The command param set X -1e-3 was 'unrecognized arguments' (taken for an option)."""
    args = build_parser().parse_args(['param', 'set', 'stand.toolface_deg', value])
    assert args.value == value


def test_a_node_name_that_is_none_is_a_usage_error():
    """The option monitor --node 'a b' was 'unexpected InvalidTopicNameException'."""
    code, out, err = quiet(['monitor', '--node', 'a b'])
    assert code == 2 and "'a b' is no ROS node name" in err and 'unexpected' not in err


def test_a_refusal_is_said_once():
    """The monitor printed 'refused: refused: no data'."""
    line = progress_text({'service': 'calibrate_level', 'state': 'refused',
                          'message': 'refused: no data; previous calibration kept'})
    assert line == ('last answer of calibrate_level: refused: no data; previous calibration '
                    'kept')
    assert progress_text({'service': 'solve_msa', 'state': 'succeeded', 'message': 'done'}) \
        == 'last answer of solve_msa: succeeded: done'


def test_fit_stand_help_names_its_own_options():
    """The command fit-stand --help named --max-std-deg, an option it does not have."""
    code, out, _ = quiet(['fit-stand', '--help'])
    text = ' '.join(out.split())
    assert code == 0 and '--max-std-deg' not in text
    for option in ('--max-drift-deg-per-s', '--max-sem-deg'):
        assert text.count(option) >= 2   # in the refusals and as an option


@pytest.mark.parametrize('date,named', [('2025-02-30', 'no day of the calendar'),
                                        ('2025-13-01', 'no day of the calendar'),
                                        ('soon', 'neither YYYY-MM-DD nor a decimal year')])
def test_a_site_date_that_is_no_day_is_named(date, named):
    """--site ... 2025-02-30 said 'could not convert string to float'."""
    with pytest.raises(ValueError, match=named):
        site_reference(['45', '7', '0', date])


class ClosedPipe(io.StringIO):
    """A stdout whose reader has gone (``| head``)."""

    def write(self, text):
        raise BrokenPipeError(32, 'Broken pipe')


def test_a_closed_pipe_ends_quietly(monkeypatch):
    """The pipe inclino param list | head said 'error: [Errno 32] Broken pipe'."""
    def listing(args):
        for k in range(1000):
            print(f'parameter_{k}: {k}')
        return 0
    monkeypatch.setattr(param, 'run', listing)
    err = io.StringIO()
    with contextlib.redirect_stdout(ClosedPipe()), contextlib.redirect_stderr(err):
        code = inclino(['param', 'list'])
    assert code == cli_main.BROKEN_PIPE and err.getvalue() == ''


def test_an_output_name_that_is_not_utf8_is_printed(tmp_path):
    """A file name that is not UTF-8 gave 'unexpected UnicodeEncodeError' after the write."""
    write_rows(tmp_path / 'in.csv', HEADER, numbered(*shots()))
    calibration(tmp_path / 'cal.json')
    output = os.fsencode(tmp_path) + b'/out\xff.csv'
    result = subprocess.run(
        [sys.executable, '-m', 'inclino_ros.cli.main', 'survey', str(tmp_path / 'in.csv'),
         '-o', output, '--calibration', str(tmp_path / 'cal.json')],
        capture_output=True, env={**os.environ, 'LC_ALL': 'C.UTF-8', 'PYTHONIOENCODING': ''})
    assert result.returncode == 0, result.stderr
    assert b'out\xff.csv' in result.stdout and os.path.exists(output)


def test_process_with_nothing_accepted_leaves_no_output(bench, tmp_path):  # noqa: F811
    """--range-mps2 1 dropped every sample, exit 1, and left its empty output bag behind."""
    _, sim, cal = bench
    code, _, err = quiet(['process', sim, tmp_path / 'out', '--calibration', cal,
                          '--range-mps2', '1'])
    assert code == 1 and 'no sample of /imu/data_raw was accepted' in err
    assert not (tmp_path / 'out').exists() and os.listdir(tmp_path) == []


@pytest.fixture(scope='module')
def result(bench, tmp_path_factory):  # noqa: F811
    """Return (RESULT bag, TRUTH bag): the bench processed."""
    _, sim, cal = bench
    out = str(tmp_path_factory.mktemp('compare') / 'out')
    code, _, err = quiet(['process', sim, out, '--calibration', cal])
    assert code == 0, err
    return out, sim


@pytest.mark.parametrize('option,value', [('--max-error-deg', '-1'),
                                          ('--max-error-deg', 'nan'),
                                          ('--min-inclination-deg', '200')])
def test_compare_options_are_checked(result, option, value):
    """The command compare took --max-error-deg -1 or nan and --min-inclination-deg 200."""
    code, out, err = quiet(['compare', *result, option, value])
    assert code == 2 and option in err and out == ''


def test_compare_of_another_topic_type_is_named(result):
    """The command compare --topic /imu/data was 'unexpected AttributeError'."""
    code, _, err = quiet(['compare', *result, '--topic', '/imu/data'])
    assert code == 2 and 'holds sensor_msgs/msg/Imu, not geometry_msgs/msg/Vector3Stamped' in err


def test_compare_with_nothing_compared_is_an_error(result, tmp_path):
    """A RESULT of another TRUTH (no common stamp): exit 0 before; now exit 2 saying so."""
    out, _ = result
    survey = bag.concatenate(bag.read(out, '/survey'))
    shifted = str(tmp_path / 'shifted')
    with bag.BagWriter(shifted) as writer:
        writer.add_topic('/survey', bag.VECTOR3_STAMPED)
        moved = bag.Vector3Series(survey.stamps_ns + 1, survey.frame_ids, survey.vector)
        writer.write(moved.stamps_ns, {'/survey': bag.encode(moved)})
    code, _, err = quiet(['compare', shifted, result[1]])
    assert code == 2 and 'nothing compared' in err
