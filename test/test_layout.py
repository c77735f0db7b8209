"""
The layers of ``inclino_ros`` and the one direction its imports run.

cli, node -> stream -> (scalar_chain ->) pipeline -> calibration -> core; io beside (it
may use core; the calibration files are written and read through it); report (the text,
residual rows and figures of the fits and comparisons) above pipeline, used by cli only;
stream (a batch corrected into outputs, a recorded bag replayed) is shared by the node and
``inclino process``; scalar_chain (pipeline's chain for a few samples in floats) is
stream's; sim (the virtual bench) is used by cli, tests and benchmarks only.  Every
module's ``inclino_ros`` imports, module-level or inside functions, are read
with ``ast`` from the source tree.
"""

import ast
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parent.parent / 'src' / 'inclino_ros'

#: What each layer may import from the package (besides itself).
ALLOWED = {
    'core': set(),
    'calibration': {'core', 'io'},
    'io': {'core'},
    'sim': {'core', 'io'},
    'report': {'core', 'calibration', 'io', 'pipeline'},
    'pipeline': {'core', 'calibration'},
    'scalar_chain': {'core', 'calibration', 'pipeline'},
    'stream': {'core', 'calibration', 'io', 'pipeline', 'scalar_chain'},
    'node': {'core', 'calibration', 'io', 'pipeline', 'stream'},
    'cli': {'core', 'calibration', 'io', 'pipeline', 'stream', 'node', 'sim', 'report'},
}


def layer_of(module):
    """Return the layer of a dotted ``inclino_ros.<layer>...`` name."""
    return module.split('.')[1]


def package_imports(path):
    """Return the ``inclino_ros`` modules ``path`` imports, anywhere in it."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] if node.module != 'inclino_ros' else [
                f'inclino_ros.{alias.name}' for alias in node.names]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        found.update(name for name in names if name.startswith('inclino_ros.'))
    return found


def sources():
    """Return (layer, path) of every module of the package but its ``__init__``."""
    for path in sorted(PACKAGE.rglob('*.py')):
        relative = path.relative_to(PACKAGE)
        if relative.name == '__init__.py' and len(relative.parts) == 1:
            continue
        yield (relative.parts[0] if len(relative.parts) > 1 else relative.stem), path


@pytest.mark.parametrize('layer,path', list(sources()), ids=lambda v: str(v))
def test_imports_run_one_way(layer, path):
    """Each module imports only from its own layer and the layers below it."""
    assert layer in ALLOWED, f'{path} is in no known layer ({layer})'
    wrong = sorted(name for name in package_imports(path)
                   if layer_of(name) != layer and layer_of(name) not in ALLOWED[layer])
    assert not wrong, f'{path.relative_to(PACKAGE)} ({layer}) must not import {wrong}'


def test_every_folder_says_what_lives_there():
    """Each layer folder has an ``__init__.py`` whose docstring describes it."""
    for folder in (p for p in PACKAGE.iterdir() if p.is_dir() and p.name != '__pycache__'):
        doc = ast.get_docstring(ast.parse((folder / '__init__.py').read_text()))
        assert doc and len(doc) > 20, f'{folder.name}/__init__.py says nothing'


def test_checker_sees_a_wrong_arrow(tmp_path):
    """The import reader finds a core -> sim import, in a function too."""
    bad = tmp_path / 'bad.py'
    bad.write_text('def f():\n    from inclino_ros.sim.bench import simulate\n'
                   'from inclino_ros import pipeline\n')
    assert package_imports(bad) == {'inclino_ros.sim.bench', 'inclino_ros.pipeline'}


def test_commands_import_no_ros():
    """Every command module imports without ROS: offline commands never load rclpy or msgs."""
    import subprocess
    import sys

    modules = sorted(f'inclino_ros.cli.{path.stem}' for path in (PACKAGE / 'cli').glob('*.py'))
    ros = ('rclpy', 'rcl_interfaces', 'sensor_msgs', 'std_msgs', 'std_srvs', 'geometry_msgs',
           'diagnostic_msgs')
    script = ('import importlib, sys\n'
              f'for name in {modules!r}:\n'
              '    importlib.import_module(name)\n'
              f'print(sorted({{m.split(".")[0] for m in sys.modules}} & set({ros!r})))\n')
    loaded = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                            check=True, timeout=120).stdout.strip()
    assert loaded == '[]', f'importing the commands loads {loaded}'
