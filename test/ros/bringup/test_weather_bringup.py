"""A day on a weather file: the weather node plays it on the ROS clock, storms happen.

The test writes a small EPW with a gale for two hours of the afternoon, runs the ``facade``
bringup on it (``--weather``) and reads the bag with rosbags: the wind on the wind topic is
the file's hour by hour (EPW convention worked out here by hand, not by the project's
reader), the storm latch trips in the gale and the panels vent to the storm position, and
after the calm hold they are scheduled again. The facade names no controller: the coordinator
runs the default, the predictive one, and says so in its log and on /diagnostics.
"""

import datetime
import subprocess

import numpy as np
import pytest
from ros_graph import BIN, domain_for, Graph
from rosbags.highlevel import AnyReader

from flectofold_model.environment import read_weather, Site, site_distance_deg
from flectofold_ros.nodes.weather import readings_at
from flectofold_ros.wire import contract, panel_states

pytestmark = pytest.mark.graph

FACADE = """
name: weather-test
site: {latitude_deg: 48.78, longitude_deg: 9.18, elevation_m: 245, utc_offset_h: 2}
facade: {azimuth_deg: 180}
surface: {type: saddle, width_m: 2.2, height_m: 2.2, curvature_u_per_m: 0.08,
          curvature_v_per_m: -0.08}
grid: {rows: 2, columns: 2, gap_m: 0.1, midrib_along: u}
panel: {fold_radius_m: 1.0, midrib_end_width_m: 0.04, hinge_width_m: 0.03,
        min_prefold_rad: 0.0873, max_moulded_prefold_rad: 0.2618, closed_clearance_m: 0.02}
control: {period_s: 60.0, shading_target: 0.9, min_dwell_s: 60.0, default_closure: 1.0,
          storm_off_delay_s: 300.0}
"""
EPW_HEADER = [
    'LOCATION,Stuttgart,BW,DEU,TEST,107380,48.83,9.20,1.0,318.0',
    'DESIGN CONDITIONS,0', 'TYPICAL/EXTREME PERIODS,0', 'GROUND TEMPERATURES,0',
    'HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0', 'COMMENTS 1,test', 'COMMENTS 2,test',
    'DATA PERIODS,1,1,Data,Sunday, 6/20,6/22',
]
CALM_M_S, GALE_M_S = 3.0, 25.0
#: EPW hours (hour ending, local standard time UTC+1) of 21 June with the gale: row h holds
#: the hour [h-1, h) local standard, [h-2, h-1) UTC, stamped at its middle h-1.5 UTC and held
#: until the next stamp, so the gale blows on the topic from 09:30 to 11:30 UTC.
GALE_HOURS = (11, 12)
GALE_UTC = (datetime.datetime(2026, 6, 21, 9, 30, tzinfo=datetime.timezone.utc),
            datetime.datetime(2026, 6, 21, 11, 30, tzinfo=datetime.timezone.utc))
PUBLISH_PERIOD_S = 10.0  # the weather node's default, of simulated time
STORM_REACH_S = 60.0  # trip delay 5 s + vent within 30 s (coordinator_node.md), with slack
RELEASE_S = 300.0  # storm_off_delay_s above
SPEEDUP = 240.0  # simulated seconds per wall second of the day below
#: The wind's bag timestamps are the recorder's simulated time at arrival, and the panels' own
#: stamps lag the wind by each hop's delivery: a few seconds of wall time on a loaded machine
#: are this many simulated seconds. Still less than the half hour an hour stamped at its start
#: or end instead of its middle would shift the gale by.
LATE_S = 5.0 * SPEEDUP
#: Largest closure a panel at the storm position reports: the loop rests once its filtered
#: pressure is within the 60 Pa hold band, and the closure comes from that filtered reading of a
#: sensor with 20 Pa of noise; 200 Pa (hold band + 7 sigma) is closure 0.05. Seen over the
#: two hours: up to 0.028 (0.02, the reach figure of coordinator_node.md, was exceeded).
FLAT = 0.05


def epw_row(month, day, hour, wind_m_s):
    dni = max(0, 80 * (12 - abs(hour - 13)))
    fields = [1995, month, day, hour, 60, 'A7A7', 20.0, 10.0, 70, 98000, 0, 1400, 350,
              dni + 100, dni, 100 if dni else 0, 0, 0, 0, 0, 200, wind_m_s, 5, 5, 20.0,
              77777, 9, '999999999', 10, 0.1, 0, 88, 0.2, 0, 1.0]
    return ','.join(str(f) for f in fields)


@pytest.fixture()
def weather_day(tmp_path):
    rows = [epw_row(6, day, hour, GALE_M_S if day == 21 and hour in GALE_HOURS else CALM_M_S)
            for day in (20, 21, 22) for hour in range(1, 25)]
    epw = tmp_path / 'gale.epw'
    epw.write_text('\n'.join(EPW_HEADER + rows) + '\n')
    facade = tmp_path / 'facade.yaml'
    facade.write_text(FACADE)
    return epw, facade


def test_the_node_plays_the_file_s_hours_and_measures_the_site(weather_day):
    weather = read_weather(weather_day[0])
    for at, wind in ((GALE_UTC[0] - datetime.timedelta(seconds=1), CALM_M_S),
                     (GALE_UTC[0], GALE_M_S), (GALE_UTC[1] - datetime.timedelta(seconds=1),
                                               GALE_M_S), (GALE_UTC[1], CALM_M_S)):
        readings = readings_at(weather, int(at.timestamp()) * 10**9, gust_factor=1.5)
        assert readings['wind_speed_m_s'] == pytest.approx(1.5 * wind), at
    noon = readings_at(weather, int(datetime.datetime(
        2026, 6, 21, 11, 30, tzinfo=datetime.timezone.utc).timestamp()) * 10**9)
    assert noon['dni_w_m2'] == pytest.approx(960.0)  # the row of hour 13, at its middle
    assert noon['wind_direction_rad'] == pytest.approx(np.radians(200.0))
    assert site_distance_deg(Site(48.78, 9.18, 245.0), weather) == pytest.approx(0.055,
                                                                                 abs=0.005)
    assert site_distance_deg(Site(25.2, 55.3, 0.0), weather) > 40.0


def test_the_node_counts_what_it_publishes_for_times_its_file_does_not_cover(weather_day):
    from rclpy.parameter import Parameter

    from flectofold_ros.nodes.weather import WeatherNode
    graph = Graph(domain_for(60))
    try:
        node = WeatherNode(context=graph.context, parameter_overrides=[
            Parameter('weather_file', value=str(weather_day[0]))])
        june = int(datetime.datetime(2026, 6, 21, 11, 30,
                                     tzinfo=datetime.timezone.utc).timestamp()) * 10**9
        node.publish_at(june)
        assert node.uncovered == 0
        node.publish_at(june + 30 * 86400 * 10**9)  # 21 July: the last reading, held
        node.publish_at(june + 31 * 86400 * 10**9)
        assert node.uncovered == 2 and node.published == 3
        node.destroy_node()
    finally:
        graph.close()


def test_a_bad_weather_file_is_refused_with_its_reason(tmp_path):
    missing = tmp_path / 'none.epw'
    result = subprocess.run([str(BIN / 'facade'), '--weather', str(missing), '--start',
                             '12:00', '--end', '12:10'], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 2, result.stdout + result.stderr
    assert f'weather file not found: {missing}' in result.stderr, result.stderr


def test_a_weather_file_that_misses_the_day_is_refused_before_anything_starts(weather_day):
    # Before, a 3-day June file was played for 15 January without a word (the first reading
    # held all day), and the file was read only after every child had started.
    epw, facade = weather_day
    result = subprocess.run([str(BIN / 'facade'), '--facade', str(facade), '--weather',
                             str(epw), '--date', '2026-01-15', '--start', '12:00', '--end',
                             '12:10'], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2, result.stdout + result.stderr
    assert 'lie(s) outside the weather file' in result.stderr and \
        'which covers 2001-06-19T23:30 .. 2001-06-22T22:30 UTC' in result.stderr, result.stderr
    assert 'ready' not in result.stdout and 'Traceback' not in result.stderr


def test_a_day_on_a_weather_file_has_its_storm(weather_day, tmp_path):
    epw, facade = weather_day
    graph = Graph(domain_for(63))
    try:
        bringup = graph.start('facade', '--facade', str(facade), '--weather', str(epw),
                              '--start', '11:00', '--end', '14:00', '--speedup', f'{SPEEDUP:g}',
                              '--panel-processes', '1', '--progress-period', '5', '--record',
                              '--out', str(tmp_path / 'out'))
        output, _ = bringup.communicate(timeout=400)
    finally:
        graph.close()
    assert bringup.returncode == 0, output
    assert 'storm latch tripped' in output and 'storm latch released' in output, output
    assert 'controller predictive' in output, output
    run = (tmp_path / 'out' / 'latest').resolve()
    wind, states, controllers = read_bag(run / 'bag')
    assert controllers and set(controllers) == {'predictive'}, controllers

    start_s, end_s = (t.timestamp() for t in GALE_UTC)
    gale = [t for t, value in wind if value == GALE_M_S]
    assert gale and {value for _, value in wind} == {CALM_M_S, GALE_M_S}
    assert start_s - LATE_S <= gale[0] <= start_s + 2 * PUBLISH_PERIOD_S + LATE_S, \
        gale[0] - start_s
    assert end_s - 2 * PUBLISH_PERIOD_S - LATE_S <= gale[-1] < end_s + LATE_S, gale[-1] - end_s

    stamps = np.array([t for t, _ in states])
    closures = np.array([table['closure'] for _, table in states])
    setpoints = np.array([table['setpoint'] for _, table in states])
    vented = (stamps > start_s + STORM_REACH_S + LATE_S) & (stamps < end_s)
    assert vented.sum() > 10 and np.all(setpoints[vented] == 0.0)
    assert np.all(closures[vented] < FLAT), closures[vented].max()
    before = stamps < start_s
    after = stamps > end_s + RELEASE_S + STORM_REACH_S
    assert closures[before].max() > 0.3, 'the sunny late morning is shaded'
    assert closures[after].max() > 0.3, 'after the storm the panels are scheduled again'


def read_bag(path):
    """Return the wind [(t, m/s)], panel states [(t, table)] and coordinator's controllers.

    The controllers: the ``controller`` value of each coordinator status on /diagnostics.
    """
    with AnyReader([path]) as reader:
        wanted = {contract.WIND_SPEED.name, contract.PANEL_STATES.name,
                  contract.DIAGNOSTICS.name}
        connections = [c for c in reader.connections if c.topic in wanted]
        wind, states, controllers = [], [], []
        for connection, timestamp, raw in reader.messages(connections=connections):
            message = reader.deserialize(raw, connection.msgtype)
            if connection.topic == contract.WIND_SPEED.name:
                wind.append((timestamp / 1e9, message.data))
            elif connection.topic == contract.DIAGNOSTICS.name:
                controllers += [
                    {kv.key: kv.value for kv in status.values}.get('controller')
                    for status in message.status
                    if status.name.endswith(f'/{contract.COORDINATOR_NODE}: schedule')]
            else:
                stamp = message.header.stamp.sec + message.header.stamp.nanosec / 1e9
                states.append((stamp, panel_states.unpack(message).copy()))
    return wind, states, controllers
