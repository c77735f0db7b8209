"""
Refused: the one base of every refusal, with its reason.

A fit, a capture or readings that cannot give a trustworthy result raise a
subclass of ``Refused`` (``StandFitRefused``, ``CaptureRefused``,
``Implausible``, ...): the message is the reason, also in ``.reason``, and
the caller keeps what it had (the previous calibration, the file untouched).
"""


class Refused(Exception):
    """Input that cannot give a trustworthy result; ``reason`` says why."""

    def __init__(self, reason):
        """Keep ``reason`` (a text) as the message and as ``.reason``."""
        super().__init__(reason)
        self.reason = reason
