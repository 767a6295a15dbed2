"""The rules of one facade per domain (:mod:`flectofold_ros.wire.presence`), without ROS."""

import pytest

from flectofold_ros.wire import contract, presence
from flectofold_ros.wire.presence import Instance


def bringup(pid, host='h1', panels=()):
    return Instance(host, pid, presence.BRINGUP, 'demo',
                    ('/facade/facade_monitor', '/facade/coordinator', '/facade/sun_position'),
                    tuple(panels), clock=True)


def panel_process(pid, panels, host='h1'):
    return Instance(host, pid, presence.PANELS, 'demo', ('/facade/panel_group_0',),
                    tuple(panels))


def test_an_announcement_reads_back_as_the_instance_it_was():
    instance = panel_process(42, ['r00c00', 'r00c01'])
    name, host, facade, values = instance.fields()
    assert presence.instance_from_fields(name, host, facade, values) == instance
    assert presence.instance_from_fields(*bringup(7).fields()) == bringup(7)


@pytest.mark.parametrize('pid', [None, '', 'x', '1.5'])
def test_an_announcement_without_a_process_id_is_refused(pid):
    values = [] if pid is None else [('pid', pid)]
    with pytest.raises(ValueError, match='without a process id'):
        presence.instance_from_fields(presence.PANELS, 'h1', 'demo', values)


def test_two_bringups_conflict_on_the_clock_and_the_coordinator():
    lines = presence.conflicts(bringup(1), [bringup(2)])
    assert lines == ["facade bringup of 'demo' (host h1, pid 2) already holds /clock, "
                     '/facade/coordinator']


def test_the_same_pid_on_another_host_is_another_process():
    assert presence.conflicts(bringup(1), [bringup(1, host='h2')])
    assert presence.conflicts(bringup(1), [bringup(1)]) == []


def test_a_process_never_conflicts_with_its_own_announcements():
    """A bringup that runs its panels announces them in a second instance, same process."""
    own_panels = panel_process(1, ['r00c00'])
    assert presence.conflicts(bringup(1), [own_panels]) == []
    assert presence.conflicts(own_panels, [bringup(1, panels=['r00c00'])]) == []


def test_panel_processes_conflict_only_on_a_shared_panel_id():
    first = panel_process(1, ['r00c00', 'r00c01'])
    assert presence.conflicts(panel_process(2, ['r01c00']), [first]) == []
    lines = presence.conflicts(panel_process(2, ['r00c01', 'r01c00']), [first])
    assert lines == ["panel process of 'demo' (host h1, pid 1) already holds panel(s) r00c01"]


def test_a_bringup_and_its_own_panel_processes_do_not_conflict():
    """The bringup announces no panels when its children run them; siblings share none."""
    children = [panel_process(10, ['r00c00']), panel_process(11, ['r00c01'])]
    assert presence.conflicts(bringup(1), children) == []
    assert presence.conflicts(children[0], [bringup(1), children[1]]) == []


def test_a_coordinator_alone_conflicts_with_a_bringups_coordinator():
    alone = Instance('h1', 5, presence.COORDINATOR, 'demo', ('/facade/coordinator',))
    assert presence.conflicts(alone, [bringup(1)]) == [
        "facade bringup of 'demo' (host h1, pid 1) already holds /facade/coordinator"]
    assert presence.conflicts(alone, [panel_process(2, ['r00c00'])]) == []


def test_a_long_list_of_shared_panels_is_quoted_short():
    ids = [f'r00c{k:02d}' for k in range(40)]
    line, = presence.conflicts(panel_process(2, ids), [panel_process(1, ids)])
    assert line.endswith('r00c00, r00c01, r00c02, r00c03 and 36 more')


def test_a_node_is_named_with_the_host_and_process_that_announced_it():
    others = [bringup(3), panel_process(4, ['r02c03'])]
    assert presence.who('/facade/coordinator', others) == (
        "/facade/coordinator (facade bringup of 'demo' (host h1, pid 3))")
    assert presence.who('/facade/r02c03/panel', others) == (
        "/facade/r02c03/panel (panel process of 'demo' (host h1, pid 4))")
    assert 'host unknown' in presence.who('/rogue/clock_source', others)


@pytest.mark.parametrize('name, panel_id', [
    ('/facade/r00c00/panel', 'r00c00'), ('/facade/r12c34/panel', 'r12c34'),
    ('/facade/r00c00/other', None), ('/elsewhere/r00c00/panel', None),
    ('/facade/r0c00/panel', None), ('/facade/coordinator', None), ('', None)])
def test_a_panel_node_name_gives_its_panel_id(name, panel_id):
    assert presence.panel_id_of(name) == panel_id


def test_a_panel_node_listed_twice_is_a_doubled_panel():
    names = ['/facade/r00c00/panel', '/facade/r00c01/panel', '/facade/r00c00/panel',
             '/facade/r00c02/panel', '/facade/r00c02/panel', '/facade/coordinator']
    assert presence.doubled_panels(names, ['r00c00', 'r00c01']) == ['r00c00']
    assert presence.doubled_panels(names, ['r00c01']) == []


def test_every_one_source_input_is_a_contract_topic_with_a_known_policy():
    topics = {topic.name for topic in vars(contract).values()
              if isinstance(topic, contract.Topic)}
    assert set(presence.ONE_SOURCE) <= topics
    assert set(presence.ONE_SOURCE.values()) <= {presence.STOP, presence.HOLD,
                                                 presence.STORM_ONLY, presence.NAME_SENDER}
    assert presence.ONE_SOURCE[contract.CLOCK.name] == presence.STOP
    assert presence.ONE_SOURCE[contract.FACADE_SETPOINTS.name] == presence.HOLD
