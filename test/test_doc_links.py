"""
The user documentation holds together: every relative link and anchor resolves.

README.md and the ``doc/*.md`` pages: a link or image to a file of the
project names a file that exists, and a ``#anchor`` (on the same page or
another) is the GitHub slug of one of that page's headings.  Internal tracker
numbers ("issue 8") are no user documentation: what changed is said where it
matters, the history is in CHANGELOG.md.
"""

import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parent.parent
PAGES = [ROOT / 'README.md'] + sorted((ROOT / 'doc').glob('*.md'))
FENCE = re.compile(r'^```.*?^```$', re.M | re.S)
LINK = re.compile(r'!?\[(?:[^\]\\]|\\.)*\]\(([^)\s]+)\)')
HEADING = re.compile(r'^(#{1,6}) +(.*?) *#*$', re.M)
TRACKER = re.compile(r'\b(?:issues?|pull request|PR)\s*#?\s*\d+', re.I)


def prose(text):
    """Return ``text`` without its fenced blocks and inline code (what holds links)."""
    text = FENCE.sub(lambda match: '\n' * match.group(0).count('\n'), text)
    return re.sub(r'`[^`\n]*`', '``', text)


def slug(heading):
    """Return GitHub's anchor of a heading: lower case, punctuation dropped, spaces to -."""
    text = re.sub(r'!?\[([^\]]*)\]\([^)]*\)', r'\1', heading).replace('`', '')
    text = re.sub(r'[^\w\- ]', '', text.strip().lower())
    return text.replace(' ', '-')


def anchors(page):
    """Return every heading anchor of ``page`` (repeats get GitHub's -1, -2 suffixes)."""
    found, seen = set(), {}
    text = FENCE.sub('', page.read_text())
    for match in HEADING.finditer(text):
        base = slug(match.group(2))
        count = seen.get(base, 0)
        seen[base] = count + 1
        found.add(base if count == 0 else f'{base}-{count}')
    return found


def links(page):
    """Return (line, target) of every link and image of ``page`` outside code."""
    text = prose(page.read_text())
    return [(text.count('\n', 0, match.start()) + 1, match.group(1))
            for match in LINK.finditer(text)]


def broken(page):
    """Return 'PAGE:LINE target (why)' for each link of ``page`` that does not resolve."""
    problems = []
    for line, target in links(page):
        if re.match(r'[a-z]+:', target):
            continue  # http(s), mailto: outside the project
        path, _, anchor = target.partition('#')
        where = f'{page.relative_to(ROOT)}:{line} {target}'
        destination = (page.parent / path).resolve() if path else page
        if not destination.exists():
            problems.append(f'{where} (no such file)')
        elif ROOT not in destination.parents and destination != ROOT:
            problems.append(f'{where} (outside the project)')
        elif anchor and (destination.suffix != '.md' or anchor not in anchors(destination)):
            problems.append(f'{where} (no such heading)')
    return problems


def test_slugs_are_githubs():
    """The anchors are those GitHub makes of the headings."""
    assert slug("Real tools' data: repeats, logs (v2)") == 'real-tools-data-repeats-logs-v2'
    assert slug('Interfaces of `inclinometer_node` (node name `inclinometer`)') == (
        'interfaces-of-inclinometer_node-node-name-inclinometer')
    assert slug('Stand and temperature calibration (seed 001), offline') == (
        'stand-and-temperature-calibration-seed-001-offline')
    assert slug('Units: m/s² and °C') == 'units-ms²-and-c'


def test_a_broken_link_is_found(tmp_path, monkeypatch):
    """A link to a missing file or heading is reported; good ones are not."""
    monkeypatch.setitem(globals(), 'ROOT', tmp_path)
    page = tmp_path / 'page.md'
    page.write_text('# Top\n\n## A `b` c\n\n[ok](#a-b-c) [top](page.md#top) [bad](#nope) '
                    '[gone](other.md) `[code](#not-a-link)`\n')
    assert broken(page) == ['page.md:5 #nope (no such heading)',
                            'page.md:5 other.md (no such file)']


def test_every_link_and_anchor_resolves():
    """Every relative link and #anchor of README.md and doc/*.md leads somewhere."""
    assert len(PAGES) >= 10
    problems = [problem for page in PAGES for problem in broken(page)]
    assert problems == []


def test_the_readme_links_every_page():
    """Each doc page is reachable from the README."""
    linked = {target.partition('#')[0] for _, target in links(ROOT / 'README.md')}
    assert {f'doc/{page.name}' for page in PAGES[1:]} <= linked


def test_no_tracker_numbers_in_user_documentation():
    """No 'issue 8', 'issue #21', 'PR 3' in README.md or doc/ (history is CHANGELOG.md's)."""
    found = [f'{page.relative_to(ROOT)}:{page.read_text().count(chr(10), 0, m.start()) + 1} '
             f'{m.group(0)!r}'
             for page in PAGES for m in TRACKER.finditer(page.read_text())]
    assert found == []
