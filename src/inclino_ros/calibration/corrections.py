"""
The calibration model: its stages in the order they are applied to every sample.

A model is an ordered set of correction stages (``stages``).  Each triad has
its own, and both share the mount.  Raw specific force (three-axis sensors; a
two-axis sensor has the mount stages only) goes through:

1. ``temperature``: seed 001 Eqs. 5-7 with a bias drift, each axis
   ``(A - B_T(T)) / K_T(T)``, with T clamped to the fitted range;
2. ``stand``: seed 001 Eqs. 10-11, ``K^-1 (A - b)`` from a multi-position
   stand (or the reference-free sphere fit); its output is the
   accelerometer frame;
3. ``installation`` (shared mount): seed 000 Eqs. 8-9, the level-bench
   angles gamma, beta;
4. ``tool_axis`` (shared mount): the same rotation found from roll groups
   (``inclino fit-magnetometer``), measured after the installation stage;
5. ``toolface_mark`` (both triads, last): the turn about the tool axis that
   ties the toolface's zero to the tool's high-side mark (issue 19 item 6).

Raw magnetometer readings [nT] go through their own stages into the
accelerometer frame, then the same mount, then seed 002's corrections:

1. ``magnetometer_temperature``: the same temperature model in nT;
2. ``magnetometer``: seed 001 Eq. 12, ``K_m^-1 (m - b_m)`` (scale,
   non-orthogonality, hard and soft iron) from the stand or the ellipsoid;
   from a stand at several temperatures K_m(T), b_m(T), as the stand's;
3. ``magnetometer_alignment``: the rotation of the magnetometer's axes into
   the accelerometer's sensing axes (identity without the stage: the
   magnetometer sits on the accelerometer's axes), then the rotation the
   accelerometer's own ``stand`` correction gives those axes
   (``Stand.rotation``), so that a new accelerometer calibration carries
   the magnetometer along;
4. ``installation``, ``tool_axis``: the shared mount, as above;
5. ``magnetometer_nonlinear``: a smooth per-axis correction of the tool-frame
   x, y fitted from roll sets (``core.nonlinear``), kept only where held-out
   roll sets showed it helps;
6. ``magnetic``: seed 002's cross-axial correction and interference;
7. ``toolface_mark``: the accelerometer's turn about the tool axis, so that G
   and B turn together (the azimuth is unchanged, the toolface tied).
"""

from dataclasses import dataclass
from functools import cached_property
import math

from inclino_ros.calibration.stages import (
    Installation, Magnetic, Magnetometer, MagnetometerAlignment,
    MagnetometerNonlinear, MagnetometerTemperature, Stand, Temperature, ToolAxis, ToolfaceMark)
from inclino_ros.core.constants import STANDARD_GRAVITY_MPS2
from inclino_ros.core.installation import to_tool_frame
from inclino_ros.core.nonlinear import correction_jacobian
from inclino_ros.core.uncertainty import affine_jacobian, level_angles_jacobian, tilt_jacobian
import numpy as np

#: The accelerometer's stages, in the order they are applied.
STAGES = ('temperature', 'stand', 'installation', 'tool_axis', 'toolface_mark')
#: The stages both triads share: the mount.
MOUNT_STAGES = ('installation', 'tool_axis')
#: The magnetometer's stages, in the order they are applied (the mount included).
MAGNETOMETER_STAGES = (('magnetometer_temperature', 'magnetometer', 'magnetometer_alignment')
                       + MOUNT_STAGES + ('magnetometer_nonlinear', 'magnetic', 'toolface_mark'))
#: What each toolface zero (``CalibrationModel.toolface_zero``, the one rule) means: the
#: words every output carrying a toolface quotes (issue 19 item 6).
TOOLFACE_ZEROS = {
    'stand': "calibrated: the tool's high side, tied by a multi-position stand",
    'mark': "calibrated: the tool's high side, tied by a capture with its high-side mark up",
    'board': 'relative to the sensor board: its roll about the tool axis is not calibrated '
             '(no stand or high-side mark), and the toolface 1 sigma leaves that offset out'}


@dataclass(frozen=True)
class CalibrationModel:
    """All corrections for one tool; a stage that is None is not applied."""

    accelerometer_axes: int
    installation: Installation = None
    stand: Stand = None
    temperature: Temperature = None
    magnetic: Magnetic = None
    tool_axis: ToolAxis = None
    magnetometer: Magnetometer = None
    magnetometer_alignment: MagnetometerAlignment = None
    magnetometer_temperature: MagnetometerTemperature = None
    magnetometer_nonlinear: MagnetometerNonlinear = None
    toolface_mark: ToolfaceMark = None
    sensor_id: str = None     # the sensor this calibration belongs to; None: not named
    # The axes maps (core.mounting) its readings were turned by before the fits:
    # (accelerometer, magnetometer); None: not recorded (older files, or no map known).
    axes_maps: tuple = None

    @property
    def stages(self):
        """Return the names of the accelerometer stages present, in their order."""
        return tuple(name for name in STAGES if getattr(self, name) is not None)

    @property
    def toolface_zero(self):
        """
        Return what the toolface's zero is tied to: ``'mark'``, ``'stand'`` or ``'board'``.

        The one rule every output carrying a toolface states (issue 19 item
        6).  A ``toolface_mark`` stage ties it to the tool's high-side mark
        (applied last, it decides whatever came before).  A stand
        calibration (``method`` ``stand``) sees the tool at known toolfaces, so
        its correction takes up the board's roll about the tool axis; a level
        bench, a rotation, a magnetometer calibration or a sphere fit (``|G| =
        g`` only) cannot see that roll: the toolface is then measured from the
        sensor board's x axis, off the tool's high side by the roll whatever
        its 1 sigma says.
        """
        if self.toolface_mark is not None:
            return 'mark'
        return 'stand' if self.stand is not None and self.stand.method == 'stand' else 'board'

    @property
    def toolface_zero_meaning(self):
        """Return what ``toolface_zero`` means, in words (``TOOLFACE_ZEROS``)."""
        return TOOLFACE_ZEROS[self.toolface_zero]

    @property
    def toolface_zero_lines(self):
        """Return the ``name: value`` lines a text output states the toolface zero with."""
        return (f'toolface_zero: {self.toolface_zero}',
                f'toolface_zero_meaning: {self.toolface_zero_meaning}')

    @property
    def magnetometer_stages(self):
        """Return the names of the magnetometer stages present (the mount included), in order."""
        return tuple(name for name in MAGNETOMETER_STAGES if getattr(self, name) is not None)

    @cached_property
    def magnetometer_rotation(self):
        """
        Return the rotation taking the magnetometer's corrected axes into the accelerometer frame.

        ``Stand.rotation`` (the turn of the accelerometer's own correction,
        identity without a stand stage) after the alignment's R (identity
        without one): the magnetometer follows the accelerometer's axes.
        """
        rotation = np.eye(3) if self.stand is None else self.stand.rotation
        if self.magnetometer_alignment is not None:
            rotation = rotation @ self.magnetometer_alignment.matrix
        return rotation

    @property
    def polynomial_stages(self):
        """
        Return the (name, stage) of the stands whose K and b are polynomials of T, in order.

        ``stand`` and ``magnetometer`` fitted at several temperature plateaus
        (``stages._PolynomialOfTemperature``): valid over their fitted range
        only, held at its nearer end beyond it.
        """
        return tuple((name, stage) for name, stage in (('stand', self.stand),
                                                       ('magnetometer', self.magnetometer))
                     if stage is not None and stage.temperature_dependent)

    @property
    def calibrated(self):
        """Whether any accelerometer correction stage is present."""
        return bool(self.stages)

    def apply(self, f, temperature_c=None, before=None):
        """
        Return corrected specific force for raw ``f`` of shape (N, 3).

        Stages run in the order of STAGES; ``before`` names a stage to stop
        at (e.g. ``before='installation'`` gives the input of a level capture).
        """
        f = np.asarray(f, dtype=float)
        for name in STAGES:
            if name == before:
                break
            stage = getattr(self, name)
            if stage is not None:
                f = stage.apply(f, temperature_c)
        return f

    def apply_magnetic(self, b_nT, temperature_c=None, before=None):
        """
        Return corrected magnetometer readings (N, 3) [nT, tool frame].

        Stages run in the order of MAGNETOMETER_STAGES, the temperature stage
        at ``temperature_c`` (None: its reference); ``before`` names one to
        stop at (``before='magnetic'``: the input of seed 002's fits).  The
        alignment's rotation is applied with the accelerometer's
        (``magnetometer_rotation``) even without an alignment stage.
        """
        b_nT = np.asarray(b_nT, dtype=float)
        for name in MAGNETOMETER_STAGES:
            if name == before:
                break
            if name == 'magnetometer_alignment':
                if self.magnetometer_alignment is not None or self.stand is not None:
                    b_nT = to_tool_frame(b_nT, self.magnetometer_rotation)
                continue
            stage = getattr(self, name)
            if stage is None:
                continue
            if name == 'magnetometer_temperature':
                b_nT = stage.apply(b_nT.reshape(-1, 3), temperature_c).reshape(b_nT.shape)
            elif name == 'magnetometer':   # K_m(T), b_m(T) of a multi-temperature stand
                b_nT = stage.apply(b_nT, temperature_c)
            else:
                b_nT = stage.apply(b_nT)
        return b_nT

    @cached_property
    def linear_map(self):
        """
        Return the 3x3 matrix the stand and mount stages apply (C^-1 K^-1), built once.

        What turns the sensor's noise into the corrected reading's (the
        temperature stage's scale, within a few percent of 1, is left out).
        """
        matrix = np.eye(3)
        if self.stand is not None:
            matrix = self._stand_inverse @ matrix
        for stage in (self.installation, self.tool_axis):
            if stage is not None:
                matrix = stage.inverse_matrix @ matrix
        return self._mark @ matrix

    def before_mark(self, vectors):
        """
        Return tool-frame vectors (N, 3) with the ``toolface_mark`` turn undone.

        The frame every magnetic fit works in (seed 002's stage comes before
        the mark): G and B of one station must be in the same one.
        """
        return np.asarray(vectors, dtype=float) @ self._mark

    @property
    def _mark(self):
        """Return the toolface mark's turn (identity without the stage)."""
        return np.eye(3) if self.toolface_mark is None else self.toolface_mark.matrix

    @property
    def tilt_std_rad(self):
        """
        Return the 1 sigma of the corrected tilt from the calibration itself [rad].

        The stages' own uncertainties, independent, added in quadrature: the
        installation capture's standard error; the stand fit's inclination
        residual and a temperature stage's fit residual as an angle against g
        only from a file that lacks the fit's parameter covariance (which
        ``parameter_blocks`` and ``temperature_covariance`` propagate instead,
        per reading).
        """
        variance = sum(stage.tilt_std_rad ** 2 for stage in (self.installation, self.stand)
                       if stage is not None)
        if self.temperature is not None and self.temperature.parameter_covariance is None:
            variance += self.temperature.residual_angle_rad(STANDARD_GRAVITY_MPS2) ** 2
        return math.sqrt(variance)

    @property
    def uncertainty_notes(self):
        """Return what the 1 sigma of this model's angles leaves out or over-states (strings)."""
        notes = []
        if self.temperature is not None and self.temperature.parameter_covariance is None:
            notes.append('temperature: the file holds no parameter covariance of the fit '
                         "(schema < 5): the tilt 1 sigma takes the heating run's residual "
                         'instead (over-stated many times); fit the temperature stage again '
                         'to record it')
        if (self.stand is not None and self.stand.method == 'stand'
                and self.stand.parameter_covariance is None and 'stand' not in
                self.covariance_stages):
            notes.append('stand: the file holds no parameter covariance of the fit (schema < 9, '
                         'or a stand at several temperatures written before it was recorded): '
                         "the tilt 1 sigma takes the fit's residual instead (over-stated); fit "
                         'the stand again to record it')
        if self.magnetometer is not None and self.magnetometer.parameter_covariance is None:
            notes.append('magnetometer: the file holds no parameter covariance of the fit '
                         '(schema < 7, or a stand at several temperatures written before it was '
                         "recorded): the azimuth 1 sigma leaves the fit's own error out "
                         '(under-stated several times); fit the magnetometer again to record it')
        if (self.magnetic is not None and self.magnetic.rotation_fitted_at is not None
                and self.magnetic.rotation_covariance is None):
            notes.append('magnetic: the file holds no parameter covariance of the rotation fit '
                         '(schema < 7): the azimuth 1 sigma leaves its own error out; fit the '
                         'rotation again to record it')
        return tuple(notes)

    @cached_property
    def magnetometer_linear_map(self):
        """
        Return the 3x3 matrix the magnetometer's stages after its temperature stage apply.

        K_m^-1, ``magnetometer_rotation``, the mount's C^-1 and seed 002's W
        on x, y (``apply_magnetic``; its offsets move no error), built once.
        """
        matrix = np.eye(3)
        if self.magnetometer is not None:
            matrix = np.linalg.inv(self.magnetometer.arrays[0]) @ matrix
        if self.magnetometer_alignment is not None or self.stand is not None:
            matrix = self.magnetometer_rotation @ matrix
        for stage in (self.installation, self.tool_axis):
            if stage is not None:
                matrix = stage.inverse_matrix @ matrix
        if self.magnetic is not None:
            soft_iron = np.eye(3)
            soft_iron[:2, :2] = self.magnetic.correction
            matrix = soft_iron @ matrix
        return self._mark @ matrix

    @property
    def covariance_stages(self):
        """
        Return the stages the magnetometer fit's parameter covariance still covers (names).

        Those of ``Magnetometer.covariance_stages`` present and fitted with it
        (the same ``fitted_at``, and as many parameters as its block: a stand
        at plateaus fitted in the same second is not the one covered): a stage
        fitted again since has its own error, its rows are left out (the
        marginal of the rest is their sub-matrix).
        """
        stage = self.magnetometer
        if stage is None or stage.parameter_covariance is None:
            return ()
        return tuple(name for name, rows in stage.covariance_blocks.items()
                     if getattr(self, name) is not None
                     and getattr(self, name).fitted_at == stage.fitted_at
                     and _parameter_count(getattr(self, name)) == rows.stop - rows.start)

    def installation_std_deg(self):
        """
        Return the 1 sigma [deg] of the installation's gamma and beta (2,); NaN without one.

        The capture's noise (``Installation.tilt_std_rad``) and, after a stand
        with a known covariance, the stand's error read through the level bench
        (``_installation_response``, seed 000 Eqs. 11-14): the variance every
        1 sigma of the pipeline takes for them, the one a fit reports.
        """
        stage = self.installation
        if stage is None:
            return np.full(2, math.nan)
        variance = np.full(2, stage.tilt_std_rad ** 2)
        layout = self._fit_layout
        covariance = layout['stand_covariance']
        if layout['installation'] is not None and covariance is not None:
            response = layout['installation'][3]
            variance = variance + np.einsum('ij,jk,ik->i', response, covariance, response)
        return np.degrees(np.sqrt(variance))

    @cached_property
    def _fit_layout(self):
        """
        Return what ``parameter_blocks`` needs of the stages, built once.

        (the covered stages, their covariance, the stand's covariance whichever
        fit holds it (its own block when the magnetometer's does not cover it),
        K^-1 of the stand, the
        magnetometer's map into the accelerometer frame, the mount's C^-1,
        seed 002's W as 3x3, the tool axis's angles [rad], the rotation fit's
        covariance, and what the stand's error does to the installation angles:
        ``_installation_response``).
        """
        soft_iron = self._mark.copy()   # what follows the mount: W, then the mark's turn
        if self.magnetic is not None:
            soft_iron[:, :2] = soft_iron[:, :2] @ self.magnetic.correction
        mount = np.eye(3)
        for stage in (self.installation, self.tool_axis):
            if stage is not None:
                mount = stage.inverse_matrix @ mount
        names, covariance = self.covariance_stages, None
        if names:
            rows = self.magnetometer.covariance_blocks
            index = np.concatenate([np.arange(rows[n].start, rows[n].stop) for n in names])
            covariance = np.array(self.magnetometer.parameter_covariance)[np.ix_(index, index)]
        if 'stand' in names:    # the first of the covered stages
            size = self.magnetometer.covariance_blocks['stand']
            stand_covariance = covariance[:size.stop - size.start, :size.stop - size.start]
        else:
            stand_covariance = (None if self.stand is None
                                or self.stand.parameter_covariance is None
                                else np.array(self.stand.parameter_covariance))
        return {
            'names': names, 'covariance': covariance, 'stand_covariance': stand_covariance,
            'soft_iron': soft_iron, 'mount': mount, 'mark': self._mark,
            'stand': self._stand_inverse,
            'magnetometer': None if self.magnetometer is None else (
                self.magnetometer_rotation @ np.linalg.inv(self.magnetometer.arrays[0])),
            'angles': None if self.tool_axis is None else (
                math.radians(self.tool_axis.gamma_deg), math.radians(self.tool_axis.beta_deg)),
            'rotation': (None if self.magnetic is None or self.magnetic.rotation_covariance is None
                         else np.array(self.magnetic.rotation_covariance)),
            'installation': self._installation_response()}

    @cached_property
    def _stand_inverse(self):
        """Return K^-1 of the stand (None without one), inverted once."""
        return None if self.stand is None else np.linalg.inv(self.stand.arrays[0])

    def _installation_response(self):
        """
        Return (gamma, beta [rad], the mount after them, d(gamma, beta)/dp (2, 12)), or None.

        A level bench measured after the stand (``solve_level_capture`` of
        ``apply(before='installation')``; one carried into a new stand's frame,
        ``magnetometer.installation_in_new_frame``, is the same reading through
        it: ``with_stand`` drops the installation otherwise) reads the stand's
        correction of the vertical tool's reading, ``v = |v| C e_z = K^-1 (a_L
        - b)``: the stand's error there moves gamma and beta by
        ``level_angles_jacobian`` times ``affine_jacobian(K v)`` (seed 000 Eqs.
        11-14), so that both stages' errors are one block, correlated.  None
        without an installation or a stand.
        """
        stage = self.installation
        if stage is None or self.stand is None:
            return None
        gamma, beta = math.radians(stage.gamma_deg), math.radians(stage.beta_deg)
        reading = stage.g_total_mps2 * stage.inverse_matrix.T[:, 2]     # C e_z |v|
        # K(T), b(T) at the temperature the bench's readings stood for (None: the stand's).
        held = self.stand.temperature_c if stage.temperature_c is None else stage.temperature_c
        matrix, bias = self.stand.at(held) if held is not None else self.stand.arrays
        inputs = (matrix @ reading + bias)[None]
        response = level_angles_jacobian(gamma, beta, stage.g_total_mps2) @ (
            self._stand_parameter_jacobian(inputs, stage.temperature_c)[0])
        after = np.eye(3) if self.tool_axis is None else self.tool_axis.inverse_matrix
        return gamma, beta, self._mark @ after, response

    def parameter_blocks(self, sensor, field_nT=None, temperature_c=None):
        """
        Return (C_p, J_f, J_B) of each fit's own error: covariance and Jacobians (M, 3, p).

        ``sensor`` (M, 3) the accelerometer's sensor vectors, ``field_nT`` (M,
        3) raw magnetometer readings in the tool axes (None: no J_B); J_f, J_B
        of the corrected specific force and field, tool frame
        (``uncertainty.affine_jacobian``, ``uncertainty.tilt_jacobian``;
        None: the block does not move that vector).  Blocks: the accelerometer
        stand fit's (``Stand.parameter_covariance``, when the magnetometer's
        does not cover it), the magnetometer fit's (``covariance_stages``), the
        non-linear stage's weights (``core.nonlinear.correction_jacobian``), the
        rotation fit's (seed 002 §2.1).
        """
        layout = self._fit_layout
        blocks = []
        count = np.shape(sensor)[0]
        soft_iron, mount = layout['soft_iron'], layout['mount']
        if layout['stand_covariance'] is not None and 'stand' not in layout['names']:
            blocks.append((layout['stand_covariance'], self._stand_jacobian(sensor, temperature_c),
                           self._stand_field_jacobian(field_nT, temperature_c)))
        if layout['names']:
            j_f, j_b = [], []
            for name in layout['names']:
                if name == 'stand':
                    j_f.append(self._stand_jacobian(sensor, temperature_c))
                    j_b.append(self._stand_field_jacobian(
                        field_nT, temperature_c,
                        np.zeros((count, 3, self.stand.coefficient_count))))
                elif name == 'magnetometer':
                    stage = self.magnetometer
                    j_f.append(np.zeros((count, 3, stage.coefficient_count)))
                    if field_nT is not None:
                        inputs = self.apply_magnetic(field_nT, temperature_c,
                                                     before='magnetometer')
                        j_b.append(soft_iron @ mount @ (
                            self.magnetometer_rotation @ stage.coefficient_jacobian(
                                inputs, temperature_c) if stage.temperature_dependent
                            else affine_jacobian(inputs - stage.arrays[1],
                                                 layout['magnetometer'])))
                else:   # the tool axis turns both triads
                    j_f.append(layout['mark'] @ tilt_jacobian(self.apply(
                        sensor, temperature_c, before='tool_axis'), *layout['angles']))
                    if field_nT is not None:
                        j_b.append(soft_iron @ tilt_jacobian(self.apply_magnetic(
                            field_nT, temperature_c, before='tool_axis'), *layout['angles']))
            blocks.append((layout['covariance'], np.concatenate(j_f, axis=2),
                           np.concatenate(j_b, axis=2) if field_nT is not None else None))
        stage = self.magnetometer_nonlinear
        if field_nT is not None and stage is not None and stage.parameter_covariance is not None:
            inputs = self.apply_magnetic(field_nT, temperature_c, before='magnetometer_nonlinear')
            blocks.append((np.array(stage.parameter_covariance), None, soft_iron @
                           correction_jacobian(inputs, stage.arrays, stage.scale_nT)))
        if field_nT is not None and layout['rotation'] is not None:
            stage = self.magnetic
            inputs = (self.apply_magnetic(field_nT, temperature_c, before='magnetic')[:, :2]
                      - stage.offset_nT)
            jacobian = np.zeros((count, 3, 6))
            jacobian[:, 0, 0:2] = jacobian[:, 1, 2:4] = inputs
            jacobian[:, :2, 4:] = -stage.correction
            blocks.append((layout['rotation'], None, layout['mark'] @ jacobian))
        mark = self.toolface_mark
        if mark is not None:    # the mark's own offset: a turn of both triads about the axis
            j_b = None if field_nT is None else mark.jacobian(
                self.apply_magnetic(field_nT, temperature_c))
            blocks.append((np.array([[math.radians(mark.std_deg) ** 2]]),
                           mark.jacobian(self.apply(sensor, temperature_c)), j_b))
        return blocks

    def _stand_jacobian(self, sensor, temperature_c):
        """
        Return d f / d(the stand's parameters) (M, 3, p) of the corrected specific force.

        One temperature: (K^-1 row-major, b), p = 12.  K(T), b(T) of a stand
        at several plateaus: their coefficients, p = 12 (order + 1), at each
        reading's temperature (``Stand.coefficient_jacobian``).  The stand's
        own turn of the reading, and, after a level bench read through it, the
        installation angles' response (``_installation_response``): at the
        bench's attitude the two cancel across the tool axis.
        """
        layout = self._fit_layout
        jacobian = layout['mark'] @ layout['mount'] @ self._stand_parameter_jacobian(
            self.apply(sensor, temperature_c, before='stand'), temperature_c)
        if layout['installation'] is not None:
            gamma, beta, after, response = layout['installation']
            corrected = self.apply(sensor, temperature_c, before='installation')
            jacobian = jacobian + after @ tilt_jacobian(corrected, gamma, beta) @ response
        return jacobian

    def _stand_field_jacobian(self, field_nT, temperature_c, otherwise=None):
        """
        Return d B / d(the stand's parameters) (M, 3, p) of the corrected field, or ``otherwise``.

        The stand does not correct the field, but a level bench read through
        it turns both triads by its gamma, beta (seed 000 Eq. 9): the stand's
        error moves them (``_installation_response``) and so the field.
        ``otherwise`` without a field or without that response.
        """
        response = self._fit_layout['installation']
        if field_nT is None or response is None:
            return otherwise
        gamma, beta, _, response = response
        after = np.eye(3) if self.tool_axis is None else self.tool_axis.inverse_matrix
        return self._fit_layout['soft_iron'] @ after @ tilt_jacobian(
            self.apply_magnetic(field_nT, temperature_c, before='installation'),
            gamma, beta) @ response

    def _stand_parameter_jacobian(self, inputs, temperature_c):
        """Return d(the stand's output) / d(its parameters) (N, 3, p) at its ``inputs`` (N, 3)."""
        stand = self.stand
        if stand.temperature_dependent:
            return stand.coefficient_jacobian(inputs, temperature_c)
        return affine_jacobian(inputs - stand.arrays[1], self._stand_inverse)

    def temperature_covariance(self, readings, temperature_c=None, triad='accelerometer'):
        """
        Return the covariance (M, 3, 3) a temperature fit's own error gives corrected readings.

        ``readings`` (M, 3) of ``triad`` (``accelerometer``: sensor vectors
        [m/s^2]; ``magnetometer``: raw fields in the tool axes [nT]); the
        stage's ``compensation_covariance`` at ``temperature_c``, through
        ``linear_map`` or ``magnetometer_linear_map``; zero without the stage.
        """
        readings = np.asarray(readings, dtype=float)
        stage, matrix = ((self.temperature, self.linear_map) if triad == 'accelerometer' else
                         (self.magnetometer_temperature, self.magnetometer_linear_map))
        if stage is None:
            return np.zeros(readings.shape + (3,))
        return matrix @ stage.compensation_covariance(readings, temperature_c) @ matrix.T

    def to_dict(self):
        """Return the JSON-ready document of this model (``schema.model_to_dict``)."""
        from inclino_ros.calibration.schema import model_to_dict
        return model_to_dict(self)


def _parameter_count(stage):
    """Return a stage's parameters in a magnetometer fit's covariance (its K, b; 2 angles)."""
    return getattr(stage, 'coefficient_count', 2)
