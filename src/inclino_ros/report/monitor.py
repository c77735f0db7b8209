"""
What ``inclino monitor`` shows: the node's latest messages kept and rendered as text lines.

A View keeps the latest survey, diagnostics statuses, calibration and
capture progress heard from the node (the messages as rclpy delivers them)
and renders them; the command (``cli/monitor.py``) subscribes and redraws.
"""

import json
import math
import os
import time

LEVELS = {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}


class View:
    """What the monitor has heard from the node, and its rendering."""

    def __init__(self, node):
        """Start with nothing heard from ``node`` (full name)."""
        self.node = node
        self.short_name = node.rsplit('/', 1)[1]
        self.survey = None
        self.surveys_in_period = 0
        self.statuses = {}
        self.progress = None
        self.calibration = None

    def on_survey(self, msg):
        """Keep the latest survey vector."""
        self.survey = (msg.vector.x, msg.vector.y, msg.vector.z)
        self.surveys_in_period += 1

    def on_diagnostics(self, msg):
        """Keep the latest status of each of the node's diagnostics."""
        for status in msg.status:
            if status.name.startswith(f'{self.short_name}: '):
                self.statuses[status.name.split(': ', 1)[1]] = status

    def on_progress(self, msg):
        """Keep the latest capture progress or service answer."""
        self.progress = json.loads(msg.data)

    def on_calibration(self, msg):
        """Keep the calibration in use."""
        self.calibration = json.loads(msg.data)

    def lines(self, period_s, waited_s, wait_s, hint):
        """
        Return the view as text lines; start a new period.

        ``hint()``: what to check when no survey came within ``wait_s``.
        """
        lines = [f'{self.node}   ROS_DOMAIN_ID={os.environ.get("ROS_DOMAIN_ID", "0")}   '
                 f'{time.strftime("%H:%M:%S")}']
        if self.survey is None:
            lines.append('angles        no survey yet'
                         + (f' -- {hint()}' if waited_s >= wait_s else ''))
        else:
            incl, toolface, azimuth = self.survey
            lines.append(f'angles        inclination {incl:9.4f} deg   toolface '
                         f'{angle_text(toolface)}   azimuth {angle_text(azimuth)}'
                         + ('' if self.surveys_in_period else
                            f'   (none in the last {period_s:g} s)'))
        inputs = self.statuses.get('input')
        if inputs is not None:
            values = {kv.key: kv.value for kv in inputs.values}
            drops = ', '.join(f'{key[8:]} {value}' for key, value in values.items()
                              if key.startswith('dropped_') and key != 'dropped_total')
            lines.append(f'input         {float(values["rate_hz"]):7.1f} samples/s   accepted '
                         f'{values["accepted_total"]}   dropped {values["dropped_total"]} '
                         f'({drops})')
        if self.calibration is not None:
            stages = ', '.join(self.calibration['stages']
                               + (['magnetic'] if self.calibration['magnetic'] else []))
            lines.append(f'calibration   {stages or "none (raw angles)"}   '
                         f'{self.calibration["calibration_file"]}')
            # The node's own statement of the toolface zero (issue 19 item 6).
            lines.append(f'toolface zero {self.calibration["toolface_zero"]}: '
                         f'{self.calibration["toolface_zero_meaning"]}')
        for index, (name, status) in enumerate(sorted(self.statuses.items())):
            level = status.level[0] if isinstance(status.level, bytes) else status.level
            lines.append(f'{"diagnostics" if index == 0 else "":<14}'
                         f'{LEVELS.get(level, str(level)):<6}{name}: {status.message}')
        if self.progress is not None:
            lines.append(f'capture       {progress_text(self.progress)}')
        self.surveys_in_period = 0
        return lines


def angle_text(value_deg):
    """Return an angle for the view; NaN (undefined or not trusted) as a dash."""
    return f'{value_deg:8.3f} deg' if math.isfinite(value_deg) else '       -    '


def progress_text(doc):
    """Return a ``~/capture_progress`` message as one line."""
    if doc['state'] == 'collecting':
        needed = '' if doc['needed'] is None else f' of {doc["needed"]}'
        spread = doc.get('spread_deg')
        return (f'{doc["service"]}: collecting {doc["samples"]}{needed} samples, '
                f'{doc["time_left_s"]:.1f} s left'
                + ('' if spread is None else f', spread {spread:.4f} deg'))
    if doc['state'] == 'collected':
        return f'{doc["service"]}: {doc["samples"]} samples collected, solving'
    message = doc.get('message', '')
    state = '' if message.startswith(f'{doc["state"]}:') else f'{doc["state"]}: '
    return f'last answer of {doc["service"]}: {state}{message}'
