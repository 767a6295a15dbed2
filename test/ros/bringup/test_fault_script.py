"""A day's fault script: checked whole when read (``test_fault_script_node.py`` plays one)."""

import datetime
import subprocess
import sys

import pytest

from flectofold_ros.bringup.fault_script import (FaultScriptError, load_document,
                                                 load_fault_script, MAX_CHARACTERS,
                                                 parse_fault_script)

FACADE = [f'r{row:02d}c{column:02d}' for row in range(6) for column in range(6)]
OFFSET_H = 2.0
ZONE = datetime.timezone(datetime.timedelta(hours=OFFSET_H))
START_S = datetime.datetime(2026, 6, 21, 12, 0, tzinfo=ZONE).timestamp()
END_S = START_S + 3 * 3600.0


def parse(text, start_s=START_S, end_s=END_S):
    return parse_fault_script(load_document(text), FACADE, start_s, end_s, OFFSET_H)


def test_a_script_gives_its_entries_in_time_order():
    script = parse("""
- {at: '12:30', panels: [r00c01, r00c02], fault: leak, conductance_m3_s_pa: 2.0e-8}
- {at: 600, panels: '*', fault: supply_loss, duration_s: 120}
- {at: 12:10:30, panels: [r00c01], fault: sensor_noise, noise_std_pa: 2e2}
- {at: '15:00', panels: '*', fault: restore}
""")
    assert [fault.offset_s for fault in script] == [600.0, 630.0, 1800.0, 10800.0]
    assert [fault.entry for fault in script] == [2, 3, 1, 4]
    leak = script[2].request
    assert leak.kind == 'leak' and leak.panels == ('r00c01', 'r00c02')
    assert leak.values == {'conductance_m3_s_pa': 2e-8}
    assert script[0].request.every_panel and script[0].request.duration_s == 120.0
    assert script[1].request.values == {'noise_std_pa': 200.0}


def test_a_day_past_midnight_takes_the_times_after_it():
    start = datetime.datetime(2026, 6, 21, 23, 0, tzinfo=ZONE).timestamp()
    script = parse("- {at: '00:30', panels: [r00c00], fault: sensor_stuck}",
                   start, start + 7200.0)
    assert script[0].offset_s == 5400.0


@pytest.mark.parametrize('text, reason', [
    ("- {at: '12:30', panels: [r00c00], fault: melt}", 'entry 1: unknown fault kind'),
    ("- {at: '12:30', panels: [r09c09], fault: sensor_stuck}", 'unknown panel'),
    ("- {at: '12:30', panels: [r00c00, r00c00], fault: sensor_stuck}", 'named twice'),
    ("- {at: '11:59', panels: '*', fault: sensor_stuck}", 'outside the day'),
    ("- {at: '15:01', panels: '*', fault: sensor_stuck}", 'outside the day'),
    ("- {at: 10801, panels: '*', fault: sensor_stuck}", 'outside the day'),
    ("- {at: -1, panels: '*', fault: sensor_stuck}", 'outside the day'),
    ("- {at: .nan, panels: '*', fault: sensor_stuck}", 'outside the day'),
    ("- {at: '25:00', panels: '*', fault: sensor_stuck}", 'no time of day'),
    ("- {at: noon, panels: '*', fault: sensor_stuck}", 'neither a local time'),
    ("- {at: true, panels: '*', fault: sensor_stuck}", 'neither a local time'),
    ("- {at: 60, panels: '*'}", 'needs fault'),
    ("- {at: 60, panels: '*', fault: leak}", 'needs conductance_m3_s_pa'),
    ("- {at: 60, panels: '*', fault: leak, conductance_m3_s_pa: .inf}", 'must lie in'),
    ("- {at: 60, panels: '*', fault: leak, conductance_m3_s_pa: -1.0e-8}", 'must lie in'),
    ("- {at: 60, panels: '*', fault: sensor_stuck, colour: red}", 'takes no value'),
    ("- {at: 60, panels: '*', fault: sensor_stuck, duration_s: 1.0e9}", 'must lie in'),
    ("- [60, '*', sensor_stuck]", 'must be a mapping'),
    ('faults: []', 'a list of entries'),
    ("- &a {at: 60, panels: '*', fault: sensor_stuck}\n- *a", 'anchors and aliases'),
    ('- {at: 60, panels: &p [r00c00], fault: sensor_stuck}', 'anchors and aliases'),
    ("- {at: 60, panels: '*', fault: sensor_stuck", 'line 1'),
    ("- {at: 60, panels: '*', fault: sensor_stuck, at: 90}",
     "line 1, column 46: key 'at' given twice"),
])
def test_a_bad_script_is_refused_naming_the_entry_and_the_reason(text, reason):
    with pytest.raises(FaultScriptError, match=reason):
        parse(text)


def test_a_script_too_long_or_unreadable_is_refused(tmp_path):
    path = tmp_path / 'faults.yaml'
    path.write_text('#' * (MAX_CHARACTERS + 1))
    with pytest.raises(FaultScriptError, match='longer than'):
        load_fault_script(path, FACADE, START_S, END_S, OFFSET_H)
    with pytest.raises(FaultScriptError, match='cannot read'):
        load_fault_script(tmp_path / 'missing.yaml', FACADE, START_S, END_S, OFFSET_H)
    path.write_text('')
    assert load_fault_script(path, FACADE, START_S, END_S, OFFSET_H) == []


def test_the_script_and_the_requests_need_no_rclpy():
    check = subprocess.run(
        [sys.executable, '-c', 'import sys\n'
         'import flectofold_ros.bringup.fault_script, flectofold_ros.wire.fault_injection\n'
         'assert "rclpy" not in sys.modules, "rclpy was imported"'],
        capture_output=True, text=True, timeout=120)
    assert check.returncode == 0, check.stderr
