"""
Part-swap of ours vs circuitpython-mag-cal on the held-out roll-set azimuth (issue 18).

Held out as in bench_sap6_peer.py (fitted on the 8 sphere shots + one roll set, judged on the
other, both ways): each instrument's roll-set azimuth RMS [deg] when the accelerometer ellipsoid,
the magnetometer ellipsoid and the axis step each come from ours (``o``) or the peer (``p``).
Variant ``XY_S``: accelerometer from X, magnetometer from Y, axis step S: ``pe`` the peer's as its
code does it (each sensor's plane normal of its roll set, the rotation applied BEFORE its
ellipsoid map), ``pc`` the same with the rotation after, ``oa`` ours on the fixed ellipsoids
(rotation from the dip + one tool axis from the roll group, ``core.shots._Model``).  ``oo_oa``
reproduces ``inclino fit-magnetometer`` (ours), ``pp_pe`` the peer's AXIS_CORRECTION (both
checked against bench_sap6_peer.py).  Knobs on our joint fit: ``nogroupweight`` (roll group not
down-weighted by its spread), ``dip_x3`` / ``dip_x0.3`` (dip residual weight / 3, x 3),
``ours_norobust`` (no outlier or wander freeing), ``acc_sphere_then_ours`` (accelerometer from
its own sphere fit, then our joint fit of the rest).
Run: ``PEER=/tmp/magcal .venv/bin/python bench/bench_sap6_partswap.py [variants] [instruments]``
(a checkout of the peer at acf6b5f), writes nothing: the table goes to stdout.
"""

import math
import os
import sys

from inclino_ros.core import shots as S
import numpy as np

sys.path.insert(0, os.environ.get('PEER', '/tmp/magcal-peer2'))
from mag_cal.sensor import Sensor  # noqa: E402,I100

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, '..', 'test', 'data')
ROLL = (np.arange(8, 16), np.arange(16, 24))


def read(folder, name):
    t = np.genfromtxt(os.path.join(DATA, folder, name + '.csv'), delimiter=',', skip_header=1)
    return t[:, :3], t[:, 3:6]


def dev(az):
    r = np.radians(az)
    mean = math.degrees(math.atan2(np.mean(np.sin(r)), np.mean(np.cos(r))))
    return (az - mean + 180.0) % 360.0 - 180.0


def azimuth(a, m, u):
    """Azimuth [deg] of axis u, a (specific force) and m in one frame."""
    down = -a / np.linalg.norm(a, axis=1)[:, None]
    east = np.cross(down, m)
    east /= np.linalg.norm(east, axis=1)[:, None]
    north = np.cross(east, down)
    return np.degrees(np.arctan2(east @ u, north @ u))


def plane_normal(v):
    """Return the peer's _find_plane: x . n = 1 least squares, normalised (sign: +z)."""
    n = np.linalg.lstsq(v, np.ones(len(v)), rcond=None)[0]
    n /= np.linalg.norm(n)
    return n if n[2] > 0 else -n


class Cal:
    """A calibration: accel map, field map (callables), axes u_a, u_m (or common)."""

    def __init__(self, fa, fm, u_a, u_m):
        self.fa, self.fm, self.u_a, self.u_m = fa, fm, u_a, u_m

    def az(self, a, m):
        a, m = self.fa(a), self.fm(m)
        if self.u_m is None:
            return azimuth(a, m, self.u_a)
        # per-sensor axes: rotate each so its axis is z (the peer's roll convention)
        return azimuth(a @ frame(self.u_a).T, m @ frame(self.u_m).T, np.array([0, 0, 1.0]))


def frame(u):
    """Return the peer's _align_to_vector for 'Z': rows x, y, z with z = u."""
    z = u / np.linalg.norm(u)
    y = np.cross(z, [1.0, 0, 0])
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    return np.array([x, y, z])


def peer_exact(pa, pm, a, m, sets):
    """
    Return the peer's axis step as its code does it: each sensor's rotation before its map.

    pa, pm: (centre, matrix M) with corrected = (v - centre) @ M.
    """
    out = []
    for (c, M), v in ((pa, a), (pm, m)):
        n = sum(plane_normal((v[s] - c) @ M) for s in sets)
        q = frame(n)
        out.append((lambda w, c=c, M=M, q=q: (w - c) @ q.T @ M))
    return Cal(out[0], out[1], np.array([0, 0, 1.0]), None)


def peer_parts(a, m):
    sa, sm = Sensor('+X+Y+Z'), Sensor('+X+Y+Z')
    sa.fit_ellipsoid(a.copy())
    sm.fit_ellipsoid(m.copy())
    return (sa.centre, sa.transform), (sm.centre, sm.transform)


def our_parts(a, m, labels, limits=S.ShotLimits()):
    f = S.fit_shots(a, m, labels, limits=limits)
    return f, (f.accel_bias_mps2, np.linalg.inv(f.accel_matrix).T), (
        f.mag_bias_nT, (f.alignment @ np.linalg.inv(f.mag_matrix)).T)


def v_peer_exact(a, m, labels, sets):
    pa, pm = peer_parts(a, m)
    return peer_exact(pa, pm, a, m, sets)


def v_our_ell_peer_exact(a, m, labels, sets):
    _, pa, pm = our_parts(a, m, labels)
    return peer_exact(pa, pm, a, m, sets)


def peer_ellipsoids(a, m):
    sa, sm = Sensor('+X+Y+Z'), Sensor('+X+Y+Z')
    sa.fit_ellipsoid(a.copy())
    sm.fit_ellipsoid(m.copy())
    return (lambda v: (v - sa.centre) @ sa.transform), (lambda v: (v - sm.centre) @ sm.transform)


def ours_fit(a, m, labels, limits=S.ShotLimits()):
    f = S.fit_shots(a, m, labels, limits=limits)
    t_a, t_m = np.linalg.inv(f.accel_matrix), f.alignment @ np.linalg.inv(f.mag_matrix)
    return f, (lambda v: (v - f.accel_bias_mps2) @ t_a.T), \
        (lambda v: (v - f.mag_bias_nT) @ t_m.T), \
        (lambda v: (v - f.mag_bias_nT) @ np.linalg.inv(f.mag_matrix).T)


def peer_axes(fa, fm, a, m, sets):
    na = sum(plane_normal(fa(a[s])) for s in sets)
    nm = sum(plane_normal(fm(m[s])) for s in sets)
    return na / np.linalg.norm(na), nm / np.linalg.norm(nm)


def our_axis_fixed(fa, fm, a, m, labels, g=9.80665):
    """Our axis step on fixed (pre-corrected) ellipsoids: R (dip) + u (groups), joint LS."""
    ac, mc = fa(a), fm(m)
    ac = ac * g / np.mean(np.linalg.norm(ac, axis=1))
    F = float(np.mean(np.linalg.norm(mc, axis=1)))
    rot, sin_dip = S._initial_rotation(ac, mc)
    k = int(labels.max()) + 1
    model = S._Model(ac, mc, labels, k, g, F, True)
    mr = mc @ rot.T
    axis = S._group_axis(ac, mr, labels, k, g, F)
    tilt = np.array(S.tilt_angles(axis))
    c_a = np.array([np.mean(ac[labels == j] @ axis) for j in range(k)])
    c_m = np.array([np.mean(mr[labels == j] @ axis) for j in range(k)])
    x0 = model.pack(np.eye(3), np.zeros(3), np.eye(3), np.zeros(3), rot, sin_dip, tilt, c_a, c_m)
    free = np.arange(18, x0.size)
    from scipy.optimize import least_squares
    model.sigma_a = model.sigma_m = 1e-3
    x = x0.copy()
    for _ in range(3):
        model.set_whitening(x)

        def res(p):
            y = x.copy()
            y[free] = p
            return model.residuals(y)
        x[free] = least_squares(res, x[free], method='lm').x
        model.set_noise(model.errors(x))
    v = model.unpack(x)
    u = S.installation_matrix(*v['tilt'])[:, 2]
    R = v['rotation']
    scale = g / np.mean(np.linalg.norm(fa(a), axis=1))
    return (lambda w: fa(w) * scale), (lambda w: fm(w) @ R.T), u


def held(name_folder, variant):
    folder, name = name_folder
    a, m = read(folder, name)
    out = []
    for fitted, judged in (ROLL, ROLL[::-1]):
        shots = np.r_[0:8, fitted]
        labels = np.r_[np.full(8, -1), np.zeros(8, int)]
        cal = variant(a[shots], m[shots], labels, [np.arange(8, 16)])
        out.append(dev(cal.az(a[judged], m[judged])))
    return np.concatenate(out)


def v_ours(a, m, labels, sets):
    f, fa, fm, _ = ours_fit(a, m, labels)
    return Cal(fa, fm, f.tool_axis, None)


def v_ours_norobust(a, m, labels, sets):
    f, fa, fm, _ = ours_fit(a, m, labels, S.ShotLimits(outlier_sigma=1e9, max_axial_rms_deg=1e9))
    return Cal(fa, fm, f.tool_axis, None)


def v_peer(a, m, labels, sets):
    fa, fm = peer_ellipsoids(a, m)
    ua, um = peer_axes(fa, fm, a, m, sets)
    return Cal(fa, fm, ua, um)


def v_our_fit_on_peer_ell(a, m, labels, sets):
    """Our whole joint fit on the peer-corrected vectors (it may refit the ellipsoids)."""
    fa, fm = peer_ellipsoids(a, m)
    sa = 9.80665
    f, ga, gm, _ = ours_fit(fa(a) * sa, fm(m) * 50000.0, labels)
    return Cal(lambda v: ga(fa(v) * sa), lambda v: gm(fm(v) * 50000.0), f.tool_axis, None)


VARIANTS = dict(ours=v_ours, peer_exact=v_peer_exact,  # noqa: C408
                our_ell_peer_exact=v_our_ell_peer_exact, ours_norobust=v_ours_norobust,
                peer=v_peer,
                our_fit_on_peer_ell=v_our_fit_on_peer_ell)
INSTRUMENTS = [('sap6', n) for n in ('BB', 'CF', 'FG', 'HC', 'IB', 'JG')] + [
    ('mag_cal_cal_data', n) for n in ('ab', 'ai', 'bh', 'bi', 'ee', 'fb', 'hj', 'hj2', 'jd')]


def main():
    names = sys.argv[1].split(',') if len(sys.argv) > 1 else list(VARIANTS)
    pick = sys.argv[2].split(',') if len(sys.argv) > 2 else None
    print('instrument ' + ' '.join(f'{n:>12.12}' for n in names))
    for inst in INSTRUMENTS:
        if pick and inst[1] not in pick:
            continue
        row = []
        for n in names:
            try:
                row.append(f'{np.sqrt(np.mean(held(inst, VARIANTS[n]) ** 2)):12.3f}')
            except Exception as err:  # noqa: B902
                row.append(f'{"ERR":>12}')
                print(n, err, file=sys.stderr)
        print(f'{inst[1]:10} ' + ' '.join(row), flush=True)


def combo(acc_src, mag_src, step):
    """Accel ellipsoid from acc_src, mag from mag_src (ours/peer), then an axis step."""
    def variant(a, m, labels, sets):
        _, oa, om = our_parts(a, m, labels)
        pa, pm = peer_parts(a, m)
        ca = oa if acc_src == 'o' else pa
        cm = om if mag_src == 'o' else pm
        if step == 'pe':
            return peer_exact(ca, cm, a, m, sets)
        fa = (lambda w: (w - ca[0]) @ ca[1])
        fm = (lambda w: (w - cm[0]) @ cm[1])
        if step == 'pc':
            ua, um = peer_axes(fa, fm, a, m, sets)
            return Cal(fa, fm, ua, um)
        fa2, fm2, u = our_axis_fixed(fa, fm, a, m, labels)
        return Cal(fa2, fm2, u, None)
    return variant


for _acc in 'op':
    for _mag in 'op':
        for _step in ('pe', 'pc', 'oa'):
            VARIANTS[f'{_acc}{_mag}_{_step}'] = combo(_acc, _mag, _step)


def pre_acc(kind):
    """Accel corrected first by its own ellipsoid (kind), then our joint fit (fit_accel=False)."""
    from inclino_ros.core.stand import fit_sphere

    def variant(a, m, labels, sets):
        if kind == 'sphere':
            sp = fit_sphere(a, 9.80665)
            fa = sp.apply
        else:
            (c, M), _ = peer_parts(a, m)
            fa = (lambda w: (w - c) @ M * 9.80665)
        f = S.fit_shots(fa(a), m, labels, fit_accel=False)
        t_m = f.alignment @ np.linalg.inv(f.mag_matrix)
        return Cal(fa, lambda w: (w - f.mag_bias_nT) @ t_m.T, f.tool_axis, None)
    return variant


VARIANTS['acc_sphere_then_ours'] = pre_acc('sphere')
VARIANTS['acc_peer_then_ours'] = pre_acc('peer')


_orig_noise = S._Model.set_noise
_orig_white = S._Model.set_whitening


def knob(kind):
    def variant(a, m, labels, sets):
        def set_noise(self, families):
            _orig_noise(self, families)
            if kind == 'nogroupweight':
                self.group_a[:], self.group_m[:] = self.sigma_a, self.sigma_m
            if kind == 'group_x3':
                self.group_a[:] *= 3
                self.group_m[:] *= 3
            if kind == 'group_div3':
                self.group_a[:] = np.maximum(self.group_a / 3, self.sigma_a)
                self.group_m[:] = np.maximum(self.group_m / 3, self.sigma_m)

        def set_whitening(self, x):
            _orig_white(self, x)
            if kind.startswith('dip_x'):
                f = float(kind[5:])
                self.whiten[:, 2, :] /= f
            if kind == 'diag':
                pass

        S._Model.set_noise, S._Model.set_whitening = set_noise, set_whitening
        try:
            return v_ours(a, m, labels, sets)
        finally:
            S._Model.set_noise, S._Model.set_whitening = _orig_noise, _orig_white
    return variant


for _k in ('nogroupweight', 'group_x3', 'group_div3', 'dip_x3', 'dip_x10', 'dip_x0.3'):
    VARIANTS[_k] = knob(_k)


if __name__ == '__main__':
    main()
