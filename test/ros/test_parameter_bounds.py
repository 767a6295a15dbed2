"""Every numeric parameter of every node, at each end of its range and one step beyond.

rclpy checks the ranges the specs declare (``parameters.py``). It takes a double within a
relative 1e-6 of an end as that end (``Node.PARAM_REL_TOL``), so "one step beyond" a double's
end is 2e-6 of it past (the smallest double past it when the end is 0); an integer's is 1.
"""

import importlib

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.exceptions import InvalidParameterValueException
from rclpy.node import Node
from ros_graph import domain_for

pytestmark = pytest.mark.graph

NODES = ('panel', 'coordinator', 'sun_position', 'weather', 'bag_recorder', 'rerun_bridge',
         'facade_markers')


def ranged():
    """``(node module, name, low, high, integer)`` of every ranged parameter."""
    for module in NODES:
        specs = importlib.import_module(f'flectofold_ros.nodes.{module}').PARAMETERS
        for name, spec in specs.items():
            descriptor = spec.descriptor
            for bounds, integer in ((descriptor.floating_point_range, False),
                                    (descriptor.integer_range, True)):
                for bound in bounds:
                    yield module, name, bound.from_value, bound.to_value, integer


RANGED = list(ranged())


def beyond(end, outward, integer):
    """One step past ``end`` in direction ``outward`` (+1 or -1)."""
    if integer:
        return end + outward
    if end == 0.0:
        return float(np.nextafter(0.0, outward))
    return end + outward * 2e-6 * abs(end)


@pytest.fixture(scope='module')
def node():
    context = Context()
    rclpy.init(context=context, domain_id=domain_for(75))
    node = Node('bounds', context=context, start_parameter_services=False)
    yield node
    node.destroy_node()
    rclpy.try_shutdown(context=context)


def declare(node, name, spec_module, value, counter=[0]):
    spec = importlib.import_module(f'flectofold_ros.nodes.{spec_module}').PARAMETERS[name]
    counter[0] += 1
    node.declare_parameter(f'{name.replace(".", "_")}_{counter[0]}', value, spec.descriptor)


def test_every_node_has_ranged_parameters():
    assert {module for module, *_ in RANGED} == set(NODES)
    assert len(RANGED) >= 30


@pytest.mark.parametrize('module, name, low, high, integer', RANGED,
                         ids=[f'{m}.{n}' for m, n, *_ in RANGED])
def test_a_parameter_takes_each_end_of_its_range_and_refuses_one_step_beyond(
        node, module, name, low, high, integer):
    for end in (low, high):
        declare(node, name, module, int(end) if integer else float(end))
    for end, outward in ((low, -1), (high, +1)):
        value = beyond(end, outward, integer)
        with pytest.raises(InvalidParameterValueException):
            declare(node, name, module, value)
