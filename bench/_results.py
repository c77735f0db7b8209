"""
The one writer of a benchmark's results file (``bench/results/*.md``), shared by every bench.

A bench builds its Markdown text and calls ``write_results``: the folder made if
missing, the file written whole (a run that failed half way leaves the old one),
the text echoed on stdout unless the bench printed it already.
"""

import os
import tempfile

#: Where the benches' results live.
RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'results')


def results_path(name):
    """Return the path of ``name`` (e.g. ``msa.md``) in ``bench/results``."""
    return os.path.join(RESULTS, name)


def write_results(path, text, echo=True):
    """Write ``text`` to ``path`` atomically (its folder made if missing); print it if ``echo``."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    handle, temporary = tempfile.mkstemp(dir=folder, prefix='.results-', suffix='.md')
    try:
        with os.fdopen(handle, 'w') as out:
            out.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o666 & ~umask)   # as open() would make it, not mkstemp's 0600
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise
    if echo:
        print(text)
