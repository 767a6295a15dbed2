"""The one contract: names by one rule, types that exist, and nobody else writes them."""

import ast
import importlib
from pathlib import Path
import re

import pytest

from flectofold_model.facade import load_facade
from flectofold_ros.wire import contract

ROOT = Path(__file__).resolve().parents[2]
#: Where the contract's topics, types and QoS may be written down.
CONTRACT_FILES = {ROOT / 'flectofold_ros' / 'wire' / 'contract.py',
                  ROOT / 'flectofold_ros' / 'runtime' / 'interfaces.py'}
#: Code that must take them from the contract: the package, launch files, tests, benchmarks.
CODE = sorted({*ROOT.glob('flectofold_ros/**/*.py'), *ROOT.glob('launch/*.py'),
               *ROOT.glob('test/**/*.py'), *ROOT.glob('bench/*.py'),
               *ROOT.glob('tools/*.py')} - CONTRACT_FILES - {Path(__file__)})
#: Calls and classes that write a topic or QoS by hand: interfaces.py wraps them.
BY_HAND = re.compile(r'\b(create_publisher|create_subscription|create_service|create_client|'
                     r'QoSProfile|DurabilityPolicy|ReliabilityPolicy|HistoryPolicy|'
                     r'qos_profile_\w+)\b')
PANEL_SUFFIXES = {topic.suffix for topic in (*contract.PANEL_OUTPUTS, contract.SETPOINT)} | \
    {contract.RESET_FAULTS_SERVICE}


def global_topics():
    return [contract.CLOCK, contract.DIAGNOSTICS, contract.SUN, contract.WIND_SPEED,
            contract.DNI, contract.OVERRIDE, contract.OVERRIDE_CLEAR, contract.FACADE_SETPOINTS]


def test_every_name_is_absolute_and_panel_names_lie_under_the_panel():
    for topic in global_topics():
        assert topic.name.startswith('/') and '//' not in topic.name, topic
    for topic in (*contract.PANEL_OUTPUTS, contract.SETPOINT):
        assert topic.of('r02c03').name == f'/facade/r02c03/{topic.suffix}'
    assert contract.reset_faults_service('r02c03') == '/facade/r02c03/reset_faults'
    assert contract.SUN.name.startswith(contract.FACADE_NAMESPACE + '/')


def test_every_type_is_an_installed_interface():
    for topic in [*global_topics(), *contract.PANEL_OUTPUTS, contract.SETPOINT]:
        package, kind, name = topic.msgtype.split('/')
        assert kind == 'msg' and hasattr(importlib.import_module(f'{package}.msg'), name)
    package, _, name = contract.RESET_FAULTS_TYPE.split('/')
    assert hasattr(importlib.import_module(f'{package}.srv'), name)


def test_the_words_on_the_topics_are_the_model_s():
    from flectofold_model.control import Fault, SetpointState
    assert contract.FAULTS == tuple(f.value for f in Fault) and contract.NO_FAULT == 'none'
    assert set(contract.STATUSES) == {s.value for s in SetpointState} | {'fault'}


def test_latched_topics_are_the_latched_ones():
    assert contract.FAULT.qos == contract.STATUS.qos == contract.LATCHED
    assert contract.LATCHED.latched and contract.LATCHED.depth == 1
    assert not any(topic.qos.latched for topic in contract.PANEL_STATE)


def test_the_demonstrator_s_ids_are_panel_ids():
    assert all(contract.PANEL_ID.fullmatch(p) for p in load_facade().panel_ids)


def string_constants(tree):
    """Every string literal of a module; an f-string with ``{}`` for what it formats."""
    parts = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.JoinedStr):
            parts.update(id(value) for value in node.values)
            yield node.lineno, ''.join(value.value if isinstance(value, ast.Constant) else '{}'
                                       for value in node.values)
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and \
                id(node) not in parts:
            yield node.lineno, node.value


def names_a_topic(text):
    """Whether a literal spells a contract topic instead of taking it from the contract."""
    facade_words = PANEL_SUFFIXES | {'sun', 'wind_speed', 'dni', 'override', 'override_clear'}
    if text in {topic.name for topic in global_topics()}:
        return True
    if text.startswith(('{}/', f'{contract.FACADE_NAMESPACE}/', 'facade/')):
        return text.rstrip('/').rsplit('/', 1)[-1] in facade_words
    return False


@pytest.mark.parametrize('path', CODE, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_topic_or_qos_is_written_outside_the_contract(path):
    text = path.read_text()
    hand_written = [(number, line.strip()) for number, line in enumerate(text.splitlines(), 1)
                    if BY_HAND.search(line) and not line.lstrip().startswith('#')]
    assert not hand_written, f'use flectofold_ros.runtime.interfaces: {hand_written}'
    spelled = [(number, value) for number, value in string_constants(ast.parse(text))
               if names_a_topic(value)]
    assert not spelled, f'take these names from flectofold_ros.wire.contract: {spelled}'
