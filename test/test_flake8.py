"""ament flake8 over the package, as in the ament_python template."""

from ament_flake8.main import main_with_errors
import pytest

CHECKED = ['src', 'test', 'bench', 'setup.py']


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8():
    """The sources pass the ament flake8 configuration."""
    rc, errors = main_with_errors(argv=CHECKED)
    assert rc == 0, f'found {len(errors)} code style errors / warnings:\n' + '\n'.join(errors)
