"""
The ``--help`` of every subcommand: what it does in the user's words, in paragraphs.

Module docstrings are written for developers (they name functions); the
description a user reads names topics, files, options and what happens.
"""

import argparse
import textwrap

WIDTH = 79


def add_command(subparsers, name, summary, *paragraphs, **options):
    """Add subcommand ``name``: ``summary`` in the list, ``paragraphs`` in its ``--help``."""
    return subparsers.add_parser(
        name, help=summary, formatter_class=argparse.RawDescriptionHelpFormatter,
        description='\n\n'.join(textwrap.fill(' '.join(text.split()), WIDTH)
                                for text in paragraphs), **options)
