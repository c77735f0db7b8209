"""The parameter table is one list: node, config YAML and doc/node-interfaces.md agree with it."""

import os

from inclino_ros.node.parameters import markdown_table, PARAMETERS
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def flatten(tree, prefix=''):
    """Return ``{'a.b': value}`` of a nested mapping."""
    flat = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f'{prefix}{key}.'))
        else:
            flat[f'{prefix}{key}'] = value
    return flat


def test_config_yaml_holds_every_default():
    """config/inclinometer.yaml sets exactly the declared parameters, to their defaults."""
    with open(os.path.join(ROOT, 'config', 'inclinometer.yaml')) as stream:
        config = yaml.safe_load(stream)
    values = flatten(config['inclinometer']['ros__parameters'])
    assert values == {p.name: p.default for p in PARAMETERS}


def test_doc_shows_the_current_parameter_table():
    """The parameter table of doc/node-interfaces.md is the one generated from the declarations."""
    with open(os.path.join(ROOT, 'doc', 'node-interfaces.md')) as stream:
        assert markdown_table() in stream.read()


def test_ranges_contain_the_defaults():
    """Every default lies inside its declared range."""
    for p in PARAMETERS:
        if p.low is not None:
            assert p.low <= p.default <= p.high, p.name
