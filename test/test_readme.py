"""
Every ``bash`` block of the README runs as written, in a fresh directory.

Each fenced block tagged ``bash`` is one test: it runs with ``bash -euo
pipefail`` in a fresh copy of the project's files (the venv shared, so it is
not built again), with HOME in that copy (``~/.ros`` is the test's own), DDS on
this host and a ROS domain of its own, and must exit 0 within its time.  A
block that prints a comparison with the truth checks it itself (it exits
non-zero on a miss).  Blocks for a full ROS 2 install (the ros2 CLI, colcon,
rosdep) are tagged ``console`` and checked by ``test_rig_path.py`` and
``scripts/test-colcon`` instead; ``scripts/test`` is the suite itself, run by CI;
usage synopses (a user's own files) are tagged ``console`` too, each with an
HTML comment saying why.
"""

import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
README = ROOT / 'README.md'
FENCE = re.compile(r'^```(\w*)\n(.*?)^```$', re.M | re.S)
#: Files of the project a block may use (the rest are not needed to run it).
PROJECT = ('scripts', 'config', 'src', 'resource', 'setup.py', 'setup.cfg', 'package.xml',
           'requirements.txt', 'requirements-test.txt', 'requirements-colcon.txt',
           'ros-constraints.txt', 'README.md', 'test/data')


def blocks(text, language='bash'):
    """Return (line, code) of every block of ``text`` tagged ``language``."""
    return [(text.count('\n', 0, match.start()) + 1, match.group(2))
            for match in FENCE.finditer(text) if match.group(1) == language]


BLOCKS = blocks(README.read_text())


def fresh_copy(tmp_path):
    """Return a folder holding the project's files and the test's venv."""
    work = tmp_path / 'project'
    work.mkdir()
    for name in PROJECT:
        source = ROOT / name
        if source.is_dir():
            shutil.copytree(source, work / name, ignore=shutil.ignore_patterns(
                '__pycache__', '*.egg-info', 'build'))
        elif source.exists():
            shutil.copy2(source, work / name)
    (work / '.venv').symlink_to(sys.prefix)
    return work


def test_blocks_are_found():
    """The README has runnable blocks, and the rig block is not among them."""
    assert len(BLOCKS) >= 3
    assert not any('ros2 run' in code for _, code in BLOCKS)


def test_every_block_not_run_says_why():
    """A ``console`` block (not run here) follows an HTML comment giving the reason."""
    lines = README.read_text().split('\n')
    for line, _ in blocks(README.read_text(), 'console'):
        before = lines[line - 2].strip()
        assert before.startswith('<!--') and before.endswith('-->'), (
            f'README.md:{line}: a console block without a comment saying why it is not run')


@pytest.mark.parametrize('line,code', BLOCKS, ids=[f'README.md:{line}' for line, _ in BLOCKS])
def test_readme_block_runs(line, code, tmp_path):
    """The block at ``line`` exits 0 in a fresh directory."""
    work = fresh_copy(tmp_path)
    env = dict(os.environ, HOME=str(work), PATH=f'{sys.prefix}/bin:{os.environ["PATH"]}',
               ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
               ROS_DOMAIN_ID=str(150 + (line + os.getpid()) % 80),
               ROS_LOG_DIR=str(tmp_path / 'log'), MPLBACKEND='Agg')
    env.pop('INCLINO_TEST_DOMAIN_ID', None)
    returncode, output = run_block(code, work, env, tmp_path / 'output.txt')
    assert returncode == 0, (
        f'README.md:{line} exited {returncode}:\n{code}\n--- output ---\n{output[-6000:]}')


def run_block(code, work, env, output_path, timeout_s=900):
    """
    Run ``code`` with bash in a session of its own; return (exit code, output).

    A block that fails half-way may leave what it started in the background
    (a node): the whole session is killed once bash ends, so that the failure
    is reported at once, with its output, and nothing outlives the test.
    """
    with open(output_path, 'w') as output:
        shell = subprocess.Popen(['bash', '-euo', 'pipefail', '-c', code], cwd=work, env=env,
                                 stdout=output, stderr=subprocess.STDOUT,
                                 start_new_session=True)
        try:
            returncode = shell.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            returncode = f'nothing: still running after {timeout_s} s'
        finally:
            try:
                os.killpg(shell.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            shell.wait()
    return returncode, output_path.read_text()
