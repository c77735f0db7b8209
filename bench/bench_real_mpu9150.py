"""
The five real MPU-9150 sessions through ``inclino fit-stand`` (a continuous log) vs the paper.

Reads the upstream logs (space separated, no header, 100 Hz: ax ay az [m/s^2], wx wy wz
[rad/s]) from ``../shared/data/real/mpu9150_multiposition`` (or the folder given), writes each
as the CSV log the command takes (``time_s`` = row / 100 Hz), runs ``inclino fit-stand`` on it
(still segments found by ``core.stillness``, one sphere reading a segment) and compares the
calibration with the paper's table (``real_imu.png``: Mikov et al., ICINS 2020).  Also: |G| - g
RMS over the still segments before (raw) and after the calibration.  Writes
``bench/results/real_mpu9150.md``.  Run: ``.venv/bin/python bench/bench_real_mpu9150.py``.
"""

import os
import subprocess
import sys
import tempfile

from _results import results_path, write_results
from inclino_ros.calibration.continuous_log import log_segments
from inclino_ros.calibration.model import load_model
from inclino_ros.core.stand import correct_stand
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT = os.path.join(HERE, '..', '..', 'shared', 'data', 'real', 'mpu9150_multiposition')
G = 9.80665
#: The paper's accelerometer table per unit: s [%], (m_yz, m_xy, m_xz) [deg], b [m/s^2].
PUBLISHED = {
    1: ((0.363, 0.315, 0.647), (0.123, 0.02, 0.317), (0.103, 0.097, 0.344)),
    2: ((0.471, 0.482, 0.932), (-0.284, -0.01, 0.145), (0.09, 0.07, 0.338)),
    3: ((0.382, 0.355, 0.78), (0.26, -0.012, 0.282), (0.096, 0.008, -0.045)),
    4: ((0.263, 0.448, 0.721), (-0.009, -0.028, -0.104), (0.065, 0.092, -0.009)),
    5: ((0.251, 0.286, 0.804), (0.056, 0.0, 0.191), (0.07, 0.036, 0.182)),
}


def main(folder=DEFAULT):
    """Fit every unit and write the table."""
    inclino = os.path.join(os.path.dirname(sys.executable), 'inclino')
    rows = []
    for unit in sorted(PUBLISHED):
        data = np.loadtxt(os.path.join(folder, f'imu{unit - 1}.log'))
        times = np.arange(data.shape[0]) / 100.0
        with tempfile.TemporaryDirectory() as work:
            log = os.path.join(work, 'log.csv')
            np.savetxt(log, np.column_stack([times, data]), delimiter=',', fmt='%.6f',
                       header='time_s,ax,ay,az,wx,wy,wz', comments='')
            done = subprocess.run([inclino, 'fit-stand', log, '--calibration',
                                   os.path.join(work, 'cal.json')], capture_output=True,
                                  text=True)
            if done.returncode:
                rows.append(f'| #{unit} | refused: {done.stderr.strip()} |||||')
                continue
            stand = load_model(os.path.join(work, 'cal.json')).stand
        k, b = np.array(stand.scale_matrix), np.array(stand.bias_mps2)
        found = log_segments(times, data[:, :3], data[:, 3:])
        raw = np.sqrt(np.mean((np.linalg.norm(found.means, axis=1) - G) ** 2))
        ours = np.sqrt(np.mean((np.linalg.norm(correct_stand(found.means, k, b), axis=1) - G)
                               ** 2))
        s_pub, m_pub, b_pub = (np.array(v) for v in PUBLISHED[unit])
        m = np.degrees([k[1, 2], k[0, 1], k[0, 2]])
        s = (np.diag(k) - 1.0) * 100.0
        rows.append(
            f'| #{unit} | {len(found.ranges)} | {raw:.4f} / {ours:.4f} | '
            f'{" ".join(f"{v:.3f}" for v in b)} ({np.abs(b - b_pub).max():.4f}) | '
            f'{" ".join(f"{v:.3f}" for v in m)} ({np.abs(m - m_pub).max():.3f}) | '
            f'{" ".join(f"{v:.3f}" for v in s)} ({np.abs(s - s_pub).max():.3f}) |')
    text = '\n'.join([
        '# Real MPU-9150 sessions: inclino fit-stand on the continuous log vs the paper',
        '',
        'bench/bench_real_mpu9150.py; the five upstream logs at 100 Hz (mikoff/imu-calib, MIT);',
        "g = 9.80665 m/s^2. In brackets: the largest difference from the paper's table.",
        '',
        '| unit | still segments | \\|G\\| - g RMS raw / ours [m/s^2] | b [m/s^2] | '
        'm_yz m_xy m_xz [deg] | s_x s_y s_z [%] |',
        '|---|---|---|---|---|---|', *rows, ''])
    write_results(results_path('real_mpu9150.md'), text)


if __name__ == '__main__':
    main(*sys.argv[1:])
