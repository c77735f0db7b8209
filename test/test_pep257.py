"""ament pep257 over the package, as in the ament_python template."""

from ament_pep257.main import main
import pytest

CHECKED = ['src', 'test', 'bench', 'setup.py']


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257():
    """The docstrings pass the ament pep257 conventions."""
    assert main(argv=CHECKED) == 0, 'found code style errors / warnings'
