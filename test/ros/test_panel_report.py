"""What a panel process reports on /diagnostics: levels, messages, figures (``panel_report``).

Pure tests: real loops of two demonstrator panels and real setpoint guards, no graph.
"""

from types import SimpleNamespace

from diagnostic_msgs.msg import DiagnosticStatus
import pytest

from flectofold_model.control import facade_loops, SetpointGuards
from flectofold_model.facade import DEFAULT_FACADE, load_facade
from flectofold_ros.wire import contract
from flectofold_ros.wire.panel_report import ERROR, OK, OVERLOADED_S, ProcessReport, WARN

IDS = ['r00c00', 'r00c01']


@pytest.fixture(scope='module')
def loops():
    built = facade_loops(load_facade(DEFAULT_FACADE), IDS, 0.1, trace=False)
    yield built
    built.close()


def test_the_levels_are_those_of_diagnostic_msgs():
    assert (OK, WARN, ERROR) == (DiagnosticStatus.OK, DiagnosticStatus.WARN,
                                 DiagnosticStatus.ERROR)


def test_a_panel_without_a_setpoint_warns_once_the_watchdog_runs_out(loops):
    report, guards = ProcessReport(2, 0.1), SetpointGuards(2, timeout_s=5.0)
    guards.offer(1, 0.5, now_s=100.0)
    feedback = loops.current_feedback()

    def status(now_s, index):
        return report.panel(index, loops, guards, guards.states(now_s), guards.command(now_s)[0],
                            feedback, 'none')

    assert status(100.0, 0)[:2] == (OK, 'waiting_for_setpoint')
    assert status(105.0, 0)[:2] == (OK, 'waiting_for_setpoint')  # at the bound
    level, message, figures = status(105.001, 0)  # just beyond it
    assert (level, message) == (WARN, 'no setpoint for 5 s: vent')
    assert figures['setpoint_state'] == 'setpoint_timeout' and figures['tracked_closure'] == 0.0
    level, message, figures = status(105.001, 1)
    assert (level, message) == (WARN, 'no setpoint for 5 s: vent')
    assert figures['setpoint'] == 0.5


def test_refused_setpoints_warn_until_the_panels_status_went_out(loops):
    report, guards = ProcessReport(2, 0.1), SetpointGuards(2, timeout_s=5.0)
    guards.offer(0, 0.3, now_s=1.0)
    assert guards.offer(0, 2.0, now_s=1.0) is not None
    report.rejected_since_report[0] += 1
    args = (loops, guards, guards.states(1.0), guards.command(1.0)[0],
            loops.current_feedback(), 'none')
    level, message, figures = report.panel(0, *args)
    assert level == WARN and message.startswith('rejected 1 setpoint(s): setpoint 2')
    assert figures[contract.DIAGNOSTIC_SETPOINTS_REJECTED] == 1
    report.reported(range(0, 1))
    assert report.panel(0, *args)[:2] == (OK, 'tracking')
    assert report.panel(0, *args[:-1], 'supply_loss')[:2] == (
        WARN, 'simulated fault injected: supply_loss')
    assert report.panel(1, *args)[0] == OK  # the other panel's count stayed its own


def test_the_process_reports_tick_jitter_and_refusals_once(loops):
    report = ProcessReport(2, 0.1)
    for now_s in (10.0, 10.1, 10.2, 10.5):
        report.tick(now_s)
    level, message, figures = report.process(loops, 2)
    assert (level, message) == (OK, '2 panels') and figures['ticks'] == 3
    assert figures[contract.DIAGNOSTIC_TICK_JITTER_P99_S] == pytest.approx(0.196, abs=1e-9)
    assert report.process(loops, 2)[2]['ticks'] == 0  # counted since the last report
    report.refuse_fault_request('no such panel r99c99')
    level, message = report.refusals(OK, '2 panels')
    assert level == WARN and message == '2 panels; refused 1 fault request(s): no such panel ' \
                                        'r99c99'
    assert report.refusals(ERROR, 'x') == (ERROR, 'x')  # once only; a worse level stays
    assert report.fault_requests_refused == 1


@pytest.mark.parametrize('behind_s, level', [
    (OVERLOADED_S, OK), (OVERLOADED_S + 0.01, WARN)])
def test_a_loop_behind_its_clock_warns_past_the_bound(loops, behind_s, level):
    late = SimpleNamespace(controller=loops.controller, behind_s=behind_s,
                           free_air_used_nl=loops.free_air_used_nl)
    guards = SetpointGuards(2, timeout_s=5.0)
    guards.offer(0, 0.3, now_s=1.0)
    result = ProcessReport(2, 0.1).panel(0, late, guards, guards.states(1.0),
                                         guards.command(1.0)[0], loops.current_feedback(),
                                         'none')
    assert result[0] == level
    assert (result[1] == 'tracking') if level == OK else result[1].startswith('overloaded')
