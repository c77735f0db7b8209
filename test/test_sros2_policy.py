"""
Issue 23 item 3: the SROS2 policy of ``config/sros2_policy.xml``.

Validated against the sros2 policy schema (``test/data/sros2_policy.xsd``, copied
from ros2/sros2 with its attribution) and against the node's own lists: only the
operator enclave may call a service that changes the calibration or set a
parameter; the outputs are readable by every enclave.  DDS security itself is
not run here: the PyPI FastDDS has no security plugins.
"""

import pathlib
import xml.etree.ElementTree as ElementTree

from inclino_ros.node.magnetic_services import CHANGING as MAGNETIC_CHANGING
from inclino_ros.node.services import CHANGING
import pytest
import xmlschema

ROOT = pathlib.Path(__file__).resolve().parent.parent
POLICY = ROOT / 'config' / 'sros2_policy.xml'
SCHEMA = ROOT / 'test' / 'data' / 'sros2_policy.xsd'
SETTERS = ('set_parameters', 'set_parameters_atomically')
OUTPUTS = ('survey', 'inclination', 'toolface', 'azimuth', 'imu/data', '/diagnostics',
           '/inclinometer/calibration')


def rules(kind, attribute, value):
    """Return {enclave: set of names} of the ``kind`` rules whose ``attribute`` is ``value``."""
    found = {}
    for enclave in ElementTree.parse(POLICY).getroot().iter('enclave'):
        names = found.setdefault(enclave.get('path'), set())
        for group in enclave.iter(f'{kind}s'):
            if group.get(attribute) == value:
                names.update(element.text for element in group.iter(kind))
    return found


def test_the_policy_is_valid_against_the_sros2_schema():
    """The schema of sros2 itself accepts the policy (read from local files only)."""
    schema = xmlschema.XMLSchema(str(SCHEMA), allow='local')
    schema.validate(str(POLICY))
    broken = POLICY.read_text().replace('request="DENY"', 'request="NO"')
    with pytest.raises(xmlschema.XMLSchemaValidationError):
        schema.validate(broken)


def test_only_the_operator_may_change_the_calibration():
    """Every changing service and the parameter setters: requested by the operator only."""
    changing = {f'/inclinometer/{name}' for name in CHANGING + MAGNETIC_CHANGING + SETTERS}
    allowed = rules('service', 'request', 'ALLOW')
    assert changing <= allowed['/inclino/operator']
    assert all(not changing & names for enclave, names in allowed.items()
               if enclave != '/inclino/operator')
    assert changing <= rules('service', 'request', 'DENY')['/inclino/observer']
    served = rules('service', 'reply', 'ALLOW')['/inclino/node']
    assert {f'~/{name}' for name in CHANGING + MAGNETIC_CHANGING + SETTERS} <= served


def test_the_outputs_are_readable_by_every_reader():
    """Operator and observer subscribe to every output; only the node publishes them."""
    readers = rules('topic', 'subscribe', 'ALLOW')
    for enclave in ('/inclino/operator', '/inclino/observer'):
        assert set(OUTPUTS) <= readers[enclave]
    publishers = rules('topic', 'publish', 'ALLOW')
    assert all(not set(OUTPUTS) & names for enclave, names in publishers.items()
               if enclave != '/inclino/node')
