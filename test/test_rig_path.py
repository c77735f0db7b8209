"""The rig section of doc/install-and-rig.md is what CI runs (scripts/test-colcon's steps)."""

import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RIG = '## On a rig with ROS 2 Jazzy installed'


def read(*path):
    """Return the text of a file of the repository."""
    with open(os.path.join(ROOT, *path)) as stream:
        return stream.read()


def rig_commands():
    """Return the ``colcon``/``source`` commands of the rig section, in order."""
    section = read('doc', 'install-and-rig.md').split(RIG, 1)[1]
    section = section.split('\n## ', 1)[0]
    # the rig block is tagged ``console`` (not run by the README check) or ``bash``
    block = re.search(r'```(?:console|bash)\n(.*?)```', section, re.DOTALL).group(1)
    commands = []
    for line in block.splitlines():
        for part in line.split('#', 1)[0].split('&&'):
            if part.strip().startswith(('colcon ', 'source ')):
                commands.append(part.strip())
    return commands


def test_ci_runs_the_readme_rig_steps_in_order():
    """Each colcon step of the rig section is a command of scripts/test-colcon, in order."""
    commands = rig_commands()
    assert commands == ['colcon list', 'colcon build --packages-select inclino_ros',
                        'source install/setup.bash',
                        'colcon test --packages-select inclino_ros',
                        'colcon test-result --verbose']
    script = [line.strip() for line in read('scripts', 'test-colcon').splitlines()]
    found = [next(i for i, line in enumerate(script)
                  if line == command or line.startswith(command + ' '))
             for command in commands]
    assert found == sorted(found)
    assert 'scripts/test-colcon' in read('.ci', 'run').splitlines()


def test_ci_starts_the_node_where_ros2_run_finds_it():
    """``ros2 run`` of the rig section is the lib/ executable with the same parameters."""
    section = read('doc', 'install-and-rig.md').split(RIG, 1)[1]
    assert ('ros2 run inclino_ros inclinometer_node --ros-args \\\n    --params-file '
            'install/inclino_ros/share/inclino_ros/config/inclinometer.yaml') in section
    script = read('scripts', 'test-colcon')
    assert 'node=$prefix/lib/inclino_ros/inclinometer_node' in script
    params = '"$prefix/share/inclino_ros/config/inclinometer.yaml"'
    assert f'"$node" --ros-args --params-file {params}' in script
