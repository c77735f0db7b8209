"""Every refusal of the package is a ``core.refusal.Refused`` with its reason."""

from inclino_ros.calibration.plausibility import Implausible
from inclino_ros.calibration.still_capture import CaptureRefused
from inclino_ros.cli.fitting import Refused as CommandRefused
from inclino_ros.core.cross_axial import fit_cross_axial, RotationFitRefused
from inclino_ros.core.msa import MsaRefused
from inclino_ros.core.refusal import Refused
from inclino_ros.core.shots import ShotFitRefused
from inclino_ros.core.stand import StandFitRefused
from inclino_ros.core.temperature import TemperatureFitRefused
import numpy as np
import pytest

KINDS = (CaptureRefused, CommandRefused, Implausible, MsaRefused, RotationFitRefused,
         ShotFitRefused, StandFitRefused, TemperatureFitRefused)


@pytest.mark.parametrize('kind', KINDS, ids=lambda kind: kind.__name__)
def test_every_refusal_is_a_refused_with_its_reason(kind):
    """One base: a caller catches Refused and reports ``.reason``, whatever refused."""
    refusal = kind('too few readings')
    assert isinstance(refusal, Refused)
    assert refusal.reason == str(refusal) == 'too few readings'


def test_implausible_stays_a_value_error():
    """Implausible is still caught where a ValueError is (a file's validation)."""
    assert issubclass(Implausible, ValueError)


def test_a_raised_refusal_carries_its_reason():
    """A real refusal (a rotation of three readings) is caught as Refused, with the reason."""
    with pytest.raises(Refused) as caught:
        fit_cross_axial(np.array([[20000.0, 0.0, 40000.0], [0.0, 20000.0, 40000.0],
                                  [-20000.0, 0.0, 40000.0]]))
    assert caught.value.reason and caught.value.reason == str(caught.value)
