"""Input health for /diagnostics: samples accepted, dropped and why, rate, G-total."""

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from inclino_ros.screening import REASONS


class InputStats:
    """Counts of the imu/data_raw stream, totals and per diagnostics period."""

    def __init__(self):
        """Start with nothing seen."""
        self.accepted_total = 0
        self.dropped_total = [0] * len(REASONS)
        self._period_accepted = 0
        self._period_dropped = 0
        self._period_g_sum = 0.0
        self._period_start_s = None

    def accept(self, g_total_mps2):
        """Count one accepted sample and its G-total."""
        self.accepted_total += 1
        self._period_accepted += 1
        self._period_g_sum += g_total_mps2

    def drop(self, code):
        """Count one dropped sample under its screening reason."""
        self.dropped_total[code] += 1
        self._period_dropped += 1

    def status(self, node_name, now_s, gravity_mps2, g_tolerance_mps2):
        """Return the input DiagnosticStatus for the period ending now; reset it."""
        elapsed = None if self._period_start_s is None else now_s - self._period_start_s
        rate_hz = self._period_accepted / elapsed if elapsed else 0.0
        g_mean = (self._period_g_sum / self._period_accepted
                  if self._period_accepted else float('nan'))
        status = DiagnosticStatus(name=f'{node_name}: input', level=DiagnosticStatus.OK)
        if self._period_accepted == 0:
            status.level = DiagnosticStatus.WARN
            status.message = ('no accepted samples on imu/data_raw'
                              + (f' ({self._period_dropped} dropped)'
                                 if self._period_dropped else ''))
        elif self._period_dropped:
            status.level = DiagnosticStatus.WARN
            status.message = f'{self._period_dropped} samples dropped in the last period'
        elif abs(g_mean - gravity_mps2) > g_tolerance_mps2:
            status.level = DiagnosticStatus.WARN
            status.message = f'G-total {g_mean:.4f} m/s^2 is off gravity {gravity_mps2}'
        else:
            status.message = f'{rate_hz:.1f} samples/s'
        values = {'rate_hz': f'{rate_hz:.2f}', 'g_total_mps2': f'{g_mean:.5f}',
                  'accepted_total': str(self.accepted_total),
                  'dropped_total': str(sum(self.dropped_total))}
        values.update({f'dropped_{reason}': str(n)
                       for reason, n in zip(REASONS, self.dropped_total)})
        status.values = [KeyValue(key=k, value=v) for k, v in values.items()]
        self._period_accepted = self._period_dropped = 0
        self._period_g_sum = 0.0
        self._period_start_s = now_s
        return status
