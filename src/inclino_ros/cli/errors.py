"""The error every ``inclino`` command reports with exit code 2."""


class CommandError(Exception):
    """A reason to stop before processing, reported with exit code 2."""
