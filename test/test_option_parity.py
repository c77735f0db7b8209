"""
One definition for each option that is a node parameter too (node and command, both doors).

Every option of the writing and processing commands whose meaning is a node parameter's is
built from the node's table (``cli.fitting.node_option``): its default, its range (or its
choices) and its meaning are the parameter's.  A twin written separately could drift (main:
fit-stand's --max-rms-deg took 1e-6 .. 90 deg where the node takes 1e-4 .. 10; fit-level's
--gravity-mps2 any number where the node takes 9.7 .. 9.9; msa's reference sigmas any
non-negative number; the node's reference dip +-90 where the commands refuse a vertical
field); this test names any that does.  An option given or not (default none) of a node
parameter's meaning takes its range (``options.node_parameter``).
"""

import argparse

from inclino_ros.cli.main import build_parser
from inclino_ros.node.parameters import PARAMETERS
import pytest

BY_NAME = {parameter.name: parameter for parameter in PARAMETERS}
#: The commands that fit, process or survey what the node does live.
COMMANDS = ('process', 'survey', 'msa', 'fit-level', 'fit-stand', 'fit-temperature',
            'fit-rotation', 'fit-magnetometer', 'fit-toolface-mark')
#: Options named as a node parameter that are not its twin, and why.
NOT_TWINS = {
    'method': "fit-stand's stand/sphere and msa's four methods (short-collar too): not the "
              "node's msa.method choices",
    'reference_total_nT': 'given or not (default none: --site, or no reference), never 0',
    'reference_dip_deg': "given or not (default none: --site); the range is the node's",
    'declination_deg': "given or not (default none: --site); the range is the node's",
    'sensor_id': 'given or not (default none: a new file unnamed)',
    'accelerometer_axes_map': 'cli.mounting: a map parsed by the rule of the node',
    'magnetometer_axes_map': 'cli.mounting: a map parsed by the rule of the node',
    'allow_left_handed_axes': 'cli.mounting: a switch',
}


def command_actions():
    """Return (command, action) of every option of COMMANDS."""
    subparsers = next(action for action in build_parser()._actions
                      if isinstance(action, argparse._SubParsersAction))
    return [(name, action) for name in COMMANDS
            for action in subparsers.choices[name]._actions if action.option_strings]


def twin_of(action):
    """Return the node parameter an option's name says it is (``dest`` = its last part)."""
    return [name for name in BY_NAME if name.split('.')[-1] == action.dest]


def accepts(action, value):
    """Return whether the option's type takes ``value`` (as the command line would give it)."""
    try:
        action.type(repr(value))
    except argparse.ArgumentTypeError:
        return False
    return True


def in_range_as_the_node(action, parameter):
    """Assert the option takes both ends of the parameter's range and refuses just beyond."""
    assert accepts(action, parameter.low) and accepts(action, parameter.high)
    step = 1 if isinstance(parameter.default, int) else 1e-9 * max(
        1.0, abs(parameter.low), abs(parameter.high))
    assert not accepts(action, parameter.low - step)
    assert not accepts(action, parameter.high + step)


@pytest.mark.parametrize('command, action', [
    pytest.param(command, action, id=f'{command} {action.option_strings[-1]}')
    for command, action in command_actions() if hasattr(action, 'node_parameter')])
def test_an_option_built_from_the_node_has_its_default_and_range(command, action):
    """Default, range (both ends taken, just beyond refused) or choices: the parameter's."""
    parameter = BY_NAME[action.node_parameter]
    assert action.default == parameter.default
    assert action.node_parameter in action.help
    if parameter.choices:
        assert tuple(action.choices) == parameter.choices
    elif parameter.low is not None:
        in_range_as_the_node(action, parameter)


@pytest.mark.parametrize('command, action', [
    pytest.param(command, action, id=f'{command} {action.option_strings[-1]}')
    for command, action in command_actions()
    if hasattr(action.type, 'parameter') and not hasattr(action, 'node_parameter')])
def test_an_optional_option_takes_the_range_of_its_node_parameter(command, action):
    """An option given or not (default none) of a node parameter's type: its range."""
    assert action.default is None
    in_range_as_the_node(action, BY_NAME[action.type.parameter])


def test_no_option_twins_a_node_parameter_on_its_own():
    """An option named as a node parameter is built from it (node_option), or listed why not."""
    twins = [f'{command} {action.option_strings[-1]} ({", ".join(twin_of(action))})'
             for command, action in command_actions()
             if twin_of(action) and not hasattr(action, 'node_parameter')
             and action.dest not in NOT_TWINS]
    assert twins == []


def test_the_stand_options_are_the_node_parameters():
    """fit-stand's stand limits and attitude sigma are the node's stand.* (issue: parity)."""
    built = {action.option_strings[-1]: action.node_parameter
             for command, action in command_actions()
             if command == 'fit-stand' and hasattr(action, 'node_parameter')}
    for flag, name in (('--max-rms-deg', 'stand.max_rms_deg'),
                       ('--attitude-sigma-deg', 'stand.attitude_sigma_deg'),
                       ('--max-field-rms-deg', 'stand.max_field_rms_deg'),
                       ('--max-sem-deg', 'stand.max_sem_deg'),
                       ('--gravity-mps2', 'gravity_mps2')):
        assert built[flag] == name
