"""
Reports that show the fit: the residual table of each fit and its calibration certificate.

Every fit command writes ``fit_NAME_certificate.html`` beside its report: a
self-contained page (figures as base64 PNG) whose numbers are those of the
calibration file (``data-field``/``data-value``), with the residual table of
the fit against its stated noise.  fit-rotation plots what the fit changes
(radial residual and direction error against the rotation angle); its
direction error is checked against the closed form of a hard iron alone.
"""

from html.parser import HTMLParser
import json
import math
import os

from inclino_ros.sim.sensor_model import read, Tool, Triad
import numpy as np
from test_calibration_history import fit_level, level_csv
from test_fit_magnetometer import outlier, shots_csv
from test_msa_cli import quiet, read_table, REFERENCE_ARGS
from test_stand_cli import HEATING_ATTITUDES_ARGS, NOISE_MPS2

HARD_IRON_NT = (80.0, -40.0, 0.0)
#: White noise of the simulated magnetometer, 1 sigma per axis [nT].
MAG_NOISE_NT = 15.0


class Page(HTMLParser):
    """Collect the data-field values, the residual rows and the images of a certificate."""

    def __init__(self):
        """Start empty."""
        super().__init__()
        self.fields, self.rows, self.images, self.ids = {}, [], [], {}
        self._id = None

    def handle_starttag(self, tag, attrs):
        """Note each data-field, residual cell, image and element with an id."""
        attrs = dict(attrs)
        if 'data-field' in attrs:
            self.fields[attrs['data-field']] = json.loads(attrs['data-value'])
        if 'data-row' in attrs:
            self.rows.append({'class': attrs.get('class')})
        if attrs.get('data-col') in ('residual', 'noise'):
            self.rows[-1][attrs['data-col']] = float(attrs['data-value'])
        if tag == 'img':
            self.images.append(attrs['src'])
        self._id = attrs.get('id')

    def handle_endtag(self, tag):
        """Text after an element's end is not its own."""
        self._id = None

    def handle_data(self, data):
        """Keep the text of an element with an id."""
        if self._id is not None:
            self.ids[self._id] = self.ids.get(self._id, '') + data


def flatten(doc, prefix=''):
    """Return {'stage.key': value} of a calibration file's JSON (nested objects joined by '.')."""
    flat = {}
    for key, value in doc.items():
        name = f'{prefix}{key}'
        if isinstance(value, dict):
            flat.update(flatten(value, f'{name}.'))
        else:
            flat[name] = value
    return flat


def parse(path):
    """Return the Page of the certificate ``path``."""
    page = Page()
    with open(path, encoding='utf-8') as stream:
        page.feed(stream.read())
    return page


def assert_certificate_is_the_file(certificate, calibration):
    """Every value of the calibration file is on the page, equal; and nothing else is."""
    with open(calibration) as stream:
        doc = json.load(stream)
    page = parse(certificate)
    expected = {key: value for key, value in flatten(doc).items() if key != 'sensor_id'}
    assert page.fields == expected
    assert page.ids['sensor-id'] == (doc.get('sensor_id') or 'not named')
    assert page.images and all(src.startswith('data:image/png;base64,') for src in page.images)
    return page


def rotation_csv(path, hard_iron_nT=HARD_IRON_NT, seed=3, **tool):
    """Write a full turn at 60 deg inclination of a tool with hard iron (sim forward model)."""
    tool = Tool(hard_iron_nT=hard_iron_nT, magnetometer=Triad(noise_std=MAG_NOISE_NT), **tool)
    toolface_deg = np.linspace(0.0, 360.0, 720, endpoint=False)
    readings = read(tool, 60.0, toolface_deg, 30.0, rng=seed)
    with open(path, 'w') as stream:
        stream.write('bx,by,bz,temperature_c\n')
        for row in readings.mag_nT:
            stream.write(f'{row[0]:.3f},{row[1]:.3f},{row[2]:.3f},31.5\n')
    return str(path), readings


def test_fit_rotation_certificate_and_direction_error(tmp_path):
    """fit-rotation: certificate = file; direction error = asin(|c| / r) of a hard iron."""
    csv, readings = rotation_csv(tmp_path / 'turn.csv')
    calibration = tmp_path / 'cal.json'
    code, _, err = quiet(['fit-rotation', csv, '--calibration', calibration,
                          '--sensor-id', 'SN-7'])
    assert code == 0, err
    certificate = tmp_path / 'fit_rotation_certificate.html'
    page = assert_certificate_is_the_file(certificate, calibration)
    assert page.ids['sensor-id'] == 'SN-7'
    assert page.fields['magnetic.rotation_temperature_c'] == 31.5
    assert page.ids['temperature-range'] == '31.50 .. 31.50 C'
    # 8 sectors of 45 deg of 90 readings, each RMS residual at the fit's RMSE (the noise it
    # states, near the simulated noise): white noise, 1 sigma of an RMS of 90 is 7.5 %
    assert len(page.rows) == 8
    assert 0.8 * MAG_NOISE_NT < page.rows[0]['noise'] < 1.2 * MAG_NOISE_NT
    with open(calibration) as stream:
        doc = json.load(stream)
    assert page.fields['magnetic.hard_iron_nT'] == doc['magnetic']['hard_iron_nT']
    for row in page.rows:
        assert row['class'] == 'used'
        assert 0.7 < row['residual'] / row['noise'] < 1.3
    # The direction error a hard iron c alone gives: at most asin(|c| / r).
    radius_nT = float(np.mean(np.hypot(*(readings.mag_nT[:, :2] - HARD_IRON_NT[:2]).T)))
    expected_deg = math.degrees(math.asin(math.hypot(*HARD_IRON_NT[:2]) / radius_nT))
    text = (tmp_path / 'fit_rotation.txt').read_text()
    stated = float(text.split('direction error the fit removes: up to ')[1].split(' deg')[0])
    assert abs(stated - expected_deg) < 0.05 * expected_deg
    assert 'radial residual per 45 deg sector of the turn' in text
    assert 'down-weighted or refused: none' in text


def test_fit_level_certificate_and_block_residuals(tmp_path):
    """fit-level: the certificate holds the file; the blocks' residuals sit at their noise."""
    csv = level_csv(tmp_path / 'level.csv', samples=1000)
    calibration = tmp_path / 'cal.json'
    code, _, err = fit_level(csv, calibration)
    assert code == 0, err
    page = assert_certificate_is_the_file(tmp_path / 'fit_level_certificate.html', calibration)
    with open(calibration) as stream:
        installation = json.load(stream)['installation']
    assert page.fields['installation.std_deg'] == installation['std_deg']
    assert len(page.rows) == 10
    noise = installation['std_deg'] / math.sqrt(200)
    ratios = np.array([row['residual'] / row['noise'] for row in page.rows])
    assert all(math.isclose(row['noise'], noise, rel_tol=1e-9) for row in page.rows)
    # white noise: the block means scatter at their stated noise (chi-square, 10 values)
    assert np.all(np.abs(ratios) < 4.5) and 0.2 < np.sqrt(np.mean(ratios ** 2)) < 2.0
    text = (tmp_path / 'fit_level.txt').read_text()
    assert text.count('block ') == 10


def test_a_refused_fit_writes_no_certificate(tmp_path):
    """Half a turn is refused: no certificate, no calibration file."""
    csv, _ = rotation_csv(tmp_path / 'turn.csv')
    with open(csv) as stream:
        rows = stream.read().splitlines()
    with open(csv, 'w') as stream:
        stream.write('\n'.join(rows[:300]) + '\n')
    code, _, _ = quiet(['fit-rotation', csv, '--calibration', tmp_path / 'cal.json'])
    assert code == 1
    assert not os.path.exists(tmp_path / 'fit_rotation_certificate.html')
    assert not os.path.exists(tmp_path / 'cal.json')


def test_msa_certificate_per_station(tmp_path):
    """Msa with --calibration: the certificate holds the file, a B-total and dip row a station."""
    stations = tmp_path / 'stations.csv'
    assert quiet(['simulate-well', stations])[0] == 0
    calibration, out_csv = tmp_path / 'cal.json', tmp_path / 'out.csv'
    code, out, err = quiet(['msa', stations, '-o', out_csv, *REFERENCE_ARGS, '--calibration',
                            calibration, '--report', tmp_path / 'msa.png'])
    assert code == 0, err
    page = assert_certificate_is_the_file(f'{out_csv}.certificate.html', calibration)
    table = read_table(out_csv)
    deltas = np.ravel(np.column_stack([table['b_total_delta_nT'], table['dip_delta_deg']]))
    assert len(page.rows) == deltas.size
    np.testing.assert_allclose([row['residual'] for row in page.rows], deltas, atol=1e-3)
    used = np.repeat(table['used'] > 0, 2)
    assert [row['class'] == 'used' for row in page.rows] == used.tolist()
    assert 'B total and dip of each station after the correction' in out
    assert f'certificate: {out_csv}.certificate.html' in out


def test_fit_magnetometer_certificate_names_the_outlier_shot(tmp_path):
    """Iron near shot 6: its row is refused in the certificate and the text; the others used."""
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-magnetometer', shots_csv(tmp_path, edit=outlier),
                            '--calibration', calibration, '--plot'])
    assert code == 0, err
    page = assert_certificate_is_the_file(tmp_path / 'fit_magnetometer_certificate.html',
                                          calibration)
    assert len(page.rows) == 24
    assert [row['class'] for row in page.rows] == ['used'] * 5 + ['refused'] + ['used'] * 18
    # The 3000 nT of iron stands far off the noise; the others' |B| about it (chi-square)
    assert abs(page.rows[5]['residual']) > 10 * page.rows[5]['noise']
    others = np.array([row['residual'] / row['noise'] for i, row in enumerate(page.rows)
                       if i != 5])
    assert np.sqrt(np.mean(others ** 2)) < 3.0
    assert 'down-weighted or refused: shot 6' in out


def test_fit_stand_and_temperature_certificates(tmp_path):
    """
    Stand: one row a position, its residual and noise those of the stand table.

    Temperature: one row a 5 C bin of the run, no per-sample noise stated (NaN).
    """
    args = ['--sensor', 'mems', '--noise-mps2', NOISE_MPS2]
    assert quiet(['simulate', tmp_path / 'stand', '--stand', *args, '--samples', 100])[0] == 0
    assert quiet(['simulate', tmp_path / 'heating', '--heating', *args, '--heating-attitudes',
                  *HEATING_ATTITUDES_ARGS, '--seed', '1'])[0] == 0
    calibration = tmp_path / 'cal.json'
    code, out, err = quiet(['fit-stand', tmp_path / 'stand', '--calibration', calibration])
    assert code == 0, err
    page = assert_certificate_is_the_file(tmp_path / 'fit_stand_certificate.html', calibration)
    lines = out.splitlines()
    header = next(i for i, line in enumerate(lines) if line.split()[:1] == ['pos'])
    names = lines[header].split()
    rows = np.array([line.split() for line in lines[header + 1:header + 1 + len(page.rows)]],
                    dtype=float)
    table = {name: rows[:, names.index(name)] for name in ('pos', 'samples', 'noise_deg',
                                                           'residual_deg')}
    assert len(page.rows) == 9 and int(table['pos'][-1]) == 9
    np.testing.assert_allclose([row['residual'] for row in page.rows], table['residual_deg'],
                               atol=1e-6)
    # the table prints noise_deg to 4 decimals: half a unit of the last, over sqrt(samples)
    noise_error = np.array([row['noise'] for row in page.rows]) - table['noise_deg'] / np.sqrt(
        table['samples'])
    assert np.all(np.abs(noise_error) <= 0.5e-4 / np.sqrt(table['samples']) + 1e-12)
    code, _, err = quiet(['fit-temperature', tmp_path / 'heating', '--calibration',
                          calibration])
    assert code == 0, err
    page = assert_certificate_is_the_file(tmp_path / 'fit_temperature_certificate.html',
                                          calibration)
    with open(calibration) as stream:
        doc = json.load(stream)
    low_c, high_c = doc['temperature']['t_min_c'], doc['temperature']['t_max_c']
    bins = np.arange(np.floor(low_c / 5.0) * 5.0, high_c, 5.0)
    assert len(page.rows) == len(bins) and all(math.isnan(row['noise']) for row in page.rows)
    stated_c = [value for key, value in flatten(doc).items()
                if key.endswith('_c') and isinstance(value, (int, float))]
    assert min(stated_c) <= low_c and max(stated_c) >= high_c
    assert page.ids['temperature-range'] == f'{min(stated_c):.2f} .. {max(stated_c):.2f} C'
