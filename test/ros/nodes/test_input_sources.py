"""The coordinator's inputs with one source: the sun held, the wind only trips, while two publish.

A coordinator node in the test's process (its own context and domain), fed by two publisher
nodes; the policies are :data:`flectofold_ros.wire.presence.ONE_SOURCE`'s.
"""

import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from ros_graph import domain_for, Graph

from flectofold_ros.nodes.coordinator import CoordinatorNode
from flectofold_ros.runtime import diagnostics
from flectofold_ros.runtime.interfaces import message_class, publisher
from flectofold_ros.wire import contract

pytestmark = pytest.mark.graph

SUN, WIND = contract.SUN.name, contract.WIND_SPEED.name


def sun_message(east, up):
    message = message_class(contract.SUN.msgtype)()
    norm = (east * east + up * up) ** 0.5
    message.vector.x, message.vector.z = east / norm, up / norm
    return message


def wind_message(speed_m_s):
    return message_class(contract.WIND_SPEED.msgtype)(data=speed_m_s)


def test_while_two_publish_the_sun_is_refused_and_the_wind_can_only_trip_the_storm(
        small_facade_text, tmp_path):
    facade_file = tmp_path / 'small.yaml'
    facade_file.write_text(small_facade_text('period_s: 60.0'))
    graph = Graph(domain_for(74))
    coordinator = CoordinatorNode(context=graph.context, parameter_overrides=[
        Parameter('facade_file', value=str(facade_file))])
    first = Node('weather_station', context=graph.context)
    second = Node('stray_station', context=graph.context)
    for node in (coordinator, first, second):
        graph.executor.add_node(node)
    try:
        sun, wind = publisher(first, contract.SUN), publisher(first, contract.WIND_SPEED)
        assert graph.spin_until(lambda: coordinator.count_subscribers(SUN) >= 1, 30)
        sun.publish(sun_message(0.0, 1.0))
        assert graph.spin_until(lambda: coordinator.schedule is not None, 30)
        wind.publish(wind_message(3.0))
        scheduler = coordinator.schedule.scheduler
        assert graph.spin_until(lambda: scheduler.wind_m_s(coordinator._now_s()) == 3.0, 30)

        stray_sun = publisher(second, contract.SUN)
        stray_wind = publisher(second, contract.WIND_SPEED)
        assert graph.spin_until(lambda: coordinator.count_publishers(SUN) == 2 and
                                coordinator.count_publishers(WIND) == 2, 30)
        held = coordinator._sun
        stray_sun.publish(sun_message(1.0, 1.0))
        assert graph.spin_until(lambda: coordinator.sources.refused[SUN] >= 1, 30)
        assert coordinator._sun == held  # not taken: which of the two sent it is unknown
        stray_wind.publish(wind_message(4.0))  # calm: refused, it could hide a storm
        assert graph.spin_until(lambda: coordinator.sources.refused[WIND] >= 1, 30)
        assert scheduler.wind_m_s(coordinator._now_s()) == 3.0
        stray_wind.publish(wind_message(30.0))  # a storm from either source trips the latch
        assert graph.spin_until(lambda: scheduler.wind_m_s(coordinator._now_s()) == 30.0, 30)
        assert coordinator.sources.refused[WIND] == 1
        assert graph.spin_until(lambda: coordinator.sources.problem(), 30)
        status = coordinator.diagnostic_status()
        assert status.level == diagnostics.ERROR
        assert f'a second source on {SUN} (2 publishers), {WIND} (2 publishers)' in \
            status.message
        figures = {kv.key: kv.value for kv in status.values}
        assert figures['second_publishers'] == '2'
        assert figures['messages_refused_for_two_sources'] == '2'

        second.destroy_publisher(stray_sun)
        second.destroy_publisher(stray_wind)
        assert graph.spin_until(lambda: coordinator.count_publishers(SUN) == 1, 30)
        sun.publish(sun_message(1.0, 1.0))
        assert graph.spin_until(lambda: coordinator._sun != held, 30)  # one source: taken
        assert graph.spin_until(lambda: not coordinator.sources.problem(), 30)
    finally:
        for node in (coordinator, first, second):
            graph.executor.remove_node(node)
            node.destroy_node()
        graph.close()
