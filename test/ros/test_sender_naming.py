"""A log line that names a message's sender waits for the graph to name it (``domain_watch``).

DDS discovery gives a writer's endpoint before the ROS graph information naming its node; a
fault request or a reset can come between the two. These tests play that order with a node
whose graph answers are scripted, and drive the naming timer by hand.
"""

from types import SimpleNamespace

import pytest

from flectofold_ros.runtime import domain_watch
from flectofold_ros.wire import contract

UNKNOWN = SimpleNamespace(node_namespace='_NODE_NAMESPACE_UNKNOWN_',
                          node_name='_NODE_NAME_UNKNOWN_')
STRANGER = SimpleNamespace(node_namespace='/', node_name='stranger')


class ScriptedNode:
    """The node's graph answers, one list of endpoints per look; its log; its one timer."""

    def __init__(self, answers):
        self.answers, self.lines, self.timers, self.topics = list(answers), [], [], []

    def get_publishers_info_by_topic(self, topic, no_mangle=False):
        self.topics.append((topic, no_mangle))
        return self.answers.pop(0) if len(self.answers) > 1 else self.answers[0]

    def get_logger(self):
        return SimpleNamespace(warning=self.lines.append)

    def create_timer(self, period_s, callback, clock=None):
        timer = SimpleNamespace(period_s=period_s, callback=callback, clock=clock, live=True)
        self.timers.append(timer)
        return timer

    def destroy_timer(self, timer):
        timer.live = False


def test_a_sender_the_graph_names_is_logged_in_the_same_line():
    node = ScriptedNode([[STRANGER]])
    domain_watch.log_with_senders(node, '/facade/inject_fault', 'fault request: x,')
    assert node.lines == ['fault request: x, from /stranger']
    assert node.timers == []


def test_a_sender_known_only_as_an_endpoint_is_named_in_a_second_line_once_the_graph_has_it():
    node = ScriptedNode([[UNKNOWN], [UNKNOWN], [STRANGER]])
    service_name = contract.reset_faults_service('r01c01')
    domain_watch.log_with_service_clients(node, service_name, 'reset_faults (supply_lost)')
    assert len(node.lines) == 1 and 'not named yet' in node.lines[0]
    assert node.lines[0].startswith('reset_faults (supply_lost) from a sender')
    timer, = node.timers
    assert timer.period_s == domain_watch.NAMING_PERIOD_S
    timer.callback()  # still unknown: nothing yet
    assert len(node.lines) == 1 and timer.live
    timer.callback()
    assert node.lines[1].startswith('reset_faults (supply_lost) from /stranger (named ')
    assert not timer.live
    assert node.topics[0] == (f'rq{service_name}Request', True)


def test_a_sender_never_named_ends_its_wait_with_a_line_saying_so(monkeypatch):
    now = [100.0]
    monkeypatch.setattr(domain_watch.time, 'monotonic', lambda: now[0])
    node = ScriptedNode([[UNKNOWN]])
    domain_watch.log_with_senders(node, '/facade/inject_fault', 'fault request: x,')
    timer, = node.timers
    now[0] += domain_watch.NAMING_S  # at the bound: still waiting
    timer.callback()
    assert len(node.lines) == 1 and timer.live
    now[0] += 0.01  # just beyond it
    timer.callback()
    assert 'still unnamed after' in node.lines[1] and not timer.live


@pytest.mark.parametrize('answer, named', [
    ([], 'a sender gone from the graph'),
    ([STRANGER, SimpleNamespace(node_namespace='/facade', node_name='coordinator')],
     'one of /facade/coordinator, /stranger'),
])
def test_no_sender_or_several_are_said_as_such(answer, named):
    node = ScriptedNode([answer])
    domain_watch.log_with_senders(node, '/t', 'line')
    assert node.lines == [f'line from {named}']
