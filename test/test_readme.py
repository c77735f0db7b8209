"""
Every ``bash`` block of the README and of every ``doc/*.md`` page runs as written.

Each fenced block tagged ``bash`` is one test (its id ``PAGE:LINE``; one page
alone: ``-k first-calibration``): it runs with ``bash -euo pipefail`` in a
fresh copy of the project's files (the venv shared, so it is not built again),
with HOME in that copy (``~/.ros`` is the test's own), DDS on this host and a
ROS domain of its own, and must exit 0 within its time.  ``BLOCKS_PER_PAGE``
says how many blocks each page runs: a block retagged or a page dropped fails
the count, so no block stops running unnoticed.  Blocks for a full ROS 2
install (the ros2 CLI, colcon, rosdep) are tagged ``console`` and checked by
``test_rig_path.py`` and ``scripts/test-colcon`` instead; ``scripts/test`` is
the suite itself, run by CI; usage synopses (a user's own files) are tagged
``console`` too, each after an HTML comment saying why.

Example outputs are compared.  A fenced block tagged ``text`` right after the
HTML comment ``<!-- output: exact -->`` or ``<!-- output: within ABS REL -->``
is what the nearest ``bash`` block above it on the page printed (stdout and
stderr together).  Every non-empty line shown must be found in that output, in
the order shown (lines of the output may be left out, never reordered): the
words and signs exactly, each number within ABS + REL x |shown| of the printed
one (``exact``: equal as numbers), any amount of blank space between words,
and ``...`` standing for any text within the line (a clock time, a temporary
path; the blank space beside it optional).  The printed output is cut into lines
at every line feed and carriage return (progress bars redraw with the latter).
``exact`` is for seeded runs; ``within`` where a live node's best-effort
input makes the last digit vary.  A ``text`` block without such a comment
before it is refused (``text`` is for compared outputs only).
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
PAGES = [ROOT / 'README.md'] + sorted((ROOT / 'doc').glob('*.md'))
#: How many ``bash`` blocks each page runs (a block that stops running fails the count).
BLOCKS_PER_PAGE = {
    'README.md': 3,
    'doc/accuracy.md': 0,
    'doc/conventions-and-calibration-file.md': 2,
    'doc/first-calibration.md': 1,
    'doc/install-and-rig.md': 1,
    'doc/magnetics.md': 1,
    'doc/method.md': 0,
    'doc/node-interfaces.md': 0,
    'doc/reliability.md': 1,
    'doc/speed.md': 0,
    'doc/stand-and-temperature.md': 5,
}
FENCE = re.compile(r'^```(\w*)\n(.*?)^```$', re.M | re.S)
OUTPUT_MARK = re.compile(r'<!-- output: (exact|within ([0-9.eE+-]+) ([0-9.eE+-]+)) -->')
NUMBER = r'[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?'
TOKEN = re.compile(rf'(\.\.\.)|({NUMBER})|(\s+)|([^\s.\d+-]+|[.+-])')
#: Files of the project a block may use (the rest are not needed to run it).
PROJECT = ('scripts', 'config', 'src', 'resource', 'setup.py', 'setup.cfg', 'package.xml',
           'requirements.txt', 'requirements-test.txt', 'requirements-colcon.txt',
           'ros-constraints.txt', 'README.md', 'doc', 'test/data')


def name_of(page):
    """Return the page's path relative to the project (``doc/speed.md``)."""
    return page.relative_to(ROOT).as_posix()


def blocks(text, language='bash'):
    """Return (line, code) of every block of ``text`` tagged ``language``."""
    return [(text.count('\n', 0, match.start()) + 1, match.group(2))
            for match in FENCE.finditer(text) if match.group(1) == language]


def shown_outputs(text):
    """
    Return {line of a bash block: [(line, tolerance, expected text), ...]}.

    An output block (``text`` after an ``<!-- output: ... -->`` comment) belongs
    to the last bash block above it; tolerance is None for ``exact``, else
    (abs, rel).
    """
    outputs, last_bash = {}, None
    for match in FENCE.finditer(text):
        line = text.count('\n', 0, match.start()) + 1
        if match.group(1) == 'bash':
            last_bash = line
        elif match.group(1) == 'text':
            before = text[:match.start()].rstrip('\n').rsplit('\n', 1)[-1].strip()
            mark = OUTPUT_MARK.fullmatch(before)
            if mark is None:
                continue
            assert last_bash is not None, f'line {line}: an output before any bash block'
            tolerance = (None if mark.group(1) == 'exact'
                         else (float(mark.group(2)), float(mark.group(3))))
            outputs.setdefault(last_bash, []).append((line, tolerance, match.group(2)))
    return outputs


def line_pattern(expected):
    """Return (regex, numbers) matching one shown line: numbers captured, ``...`` any text."""
    tokens = TOKEN.findall(expected.strip())
    parts, numbers = [r'\s*'], []
    for index, (wildcard, number, space, word) in enumerate(tokens):
        if wildcard:
            parts.append('.*?')
        elif number:
            parts.append(f'({NUMBER})')
            numbers.append(float(number))
        elif space:
            beside = tokens[index - 1][0] or (index + 1 < len(tokens) and tokens[index + 1][0])
            parts.append(r'\s*' if beside else r'\s+')
        else:
            parts.append(re.escape(word))
    parts.append(r'\s*')
    return re.compile(''.join(parts)), numbers


def output_misses(expected, printed, tolerance):
    """Return the shown lines not found, in order, in the printed output (empty: all found)."""
    printed_lines = re.split(r'[\r\n]', printed)  # progress bars redraw after a carriage return
    misses, start = [], 0
    for shown in (line for line in expected.split('\n') if line.strip()):
        pattern, numbers = line_pattern(shown)
        for index in range(start, len(printed_lines)):
            match = pattern.fullmatch(printed_lines[index])
            if match and all(numbers_agree(float(got), want, tolerance)
                             for got, want in zip(match.groups(), numbers)):
                start = index + 1
                break
        else:
            misses.append(shown)
    return misses


def numbers_agree(got, want, tolerance):
    """Return whether a printed number is the shown one (exactly, or within the tolerance)."""
    if tolerance is None:
        return got == want
    absolute, relative = tolerance
    return abs(got - want) <= absolute + relative * abs(want)


CASES = [(page, line, code, shown_outputs(page.read_text()).get(line, []))
         for page in PAGES for line, code in blocks(page.read_text())]


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


def test_every_page_runs_its_counted_blocks():
    """Each page holds exactly the bash blocks counted, and the rig block is not among them."""
    found = {name_of(page): len(blocks(page.read_text())) for page in PAGES}
    assert found == BLOCKS_PER_PAGE
    assert not any('ros2 run' in code for _, _, code, _ in CASES)


def test_every_output_shown_is_compared():
    """Each ``<!-- output`` mark precedes a ``text`` block; each ``text`` block is compared."""
    for page in PAGES:
        text = page.read_text()
        marks = len(re.findall(r'^\s*<!-- output', text, re.M))
        compared = sum(len(outputs) for outputs in shown_outputs(text).values())
        assert marks == compared == len(blocks(text, 'text')), (
            f'{name_of(page)}: {marks} output marks, {compared} compared, '
            f'{len(blocks(text, "text"))} text blocks')
    assert sum(len(outputs) for _, _, _, outputs in CASES) >= 10


def test_every_block_not_run_says_why():
    """A ``console`` block (not run here) follows an HTML comment giving the reason."""
    for page in PAGES:
        text = page.read_text()
        lines = text.split('\n')
        for line, _ in blocks(text, 'console'):
            before = lines[line - 2].strip()
            assert before.startswith('<!--') and before.endswith('-->'), (
                f'{name_of(page)}:{line}: a console block without a comment saying why it '
                'is not run')


def test_output_comparison_finds_what_differs():
    """The comparison passes the printed text, and fails a changed word, number or order."""
    printed = 'st  err I\n  1    0.0021   trusted 196\nworst 0.0022 deg at 17:19:35\n'
    assert output_misses(' 1  0.0021 trusted 196\nworst 0.0022 deg at ...', printed, None) == []
    assert output_misses('1 0.0022 trusted 196', printed, None) != []
    assert output_misses('1 0.0022 trusted 196', printed, (0.0002, 0)) == []
    assert output_misses('1 0.0021 trusted 0', printed, (0.0002, 0)) != []
    assert output_misses('1 0.0021 spread 196', printed, None) != []
    assert output_misses('worst 0.0022 deg at ...\nst err I', printed, None) != []


def test_files_shown_are_files_the_package_reads(tmp_path):
    """A calibration file shown loads at the current schema; a parameters file names parameters."""
    from inclino_ros.calibration.migrations import SCHEMA_VERSION
    from inclino_ros.calibration.store import load_model
    from inclino_ros.node.parameters import PARAMETERS
    import yaml
    names = {p.name for p in PARAMETERS}
    shown = 0
    for page in PAGES:
        for line, text in blocks(page.read_text(), 'json'):
            path = tmp_path / f'{page.stem}-{line}.json'
            path.write_text(text)
            assert '"schema_version": %d,' % SCHEMA_VERSION in text, f'{name_of(page)}:{line}'
            assert load_model(str(path)) is not None
            shown += 1
        for line, text in blocks(page.read_text(), 'yaml'):
            parameters = yaml.safe_load(text)['inclinometer']['ros__parameters']
            assert set(parameters) <= names, f'{name_of(page)}:{line}'
            shown += 1
    assert shown >= 2


@pytest.mark.parametrize('page,line,code,outputs', CASES,
                         ids=[f'{name_of(page)}:{line}' for page, line, _, _ in CASES])
def test_block_runs(page, line, code, outputs, tmp_path):
    """The block at ``line`` exits 0 in a fresh directory and prints the outputs shown."""
    work = fresh_copy(tmp_path)
    env = dict(os.environ, HOME=str(work), PATH=f'{sys.prefix}/bin:{os.environ["PATH"]}',
               ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
               ROS_DOMAIN_ID=str(150 + (line + len(name_of(page)) + os.getpid()) % 80),
               ROS_LOG_DIR=str(tmp_path / 'log'), MPLBACKEND='Agg')
    env.pop('INCLINO_TEST_DOMAIN_ID', None)
    returncode, output = run_block(code, work, env, tmp_path / 'output.txt')
    where = f'{name_of(page)}:{line}'
    assert returncode == 0, (
        f'{where} exited {returncode}:\n{code}\n--- output ---\n{output[-6000:]}')
    for shown_line, tolerance, expected in outputs:
        misses = output_misses(expected, output, tolerance)
        assert not misses, (
            f'{name_of(page)}:{shown_line}: the output shown is not what {where} printed; '
            f'not found (in order): {misses}\n--- printed ---\n{output[-8000:]}')


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
