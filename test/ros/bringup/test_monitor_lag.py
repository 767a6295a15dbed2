"""How far the slowest panel trails the clock, as the bringup's monitor reckons it."""

import math

import numpy as np

from flectofold_ros.bringup.monitor import silence_s, trailing_s

START_S = 1000.0
NAN = math.nan


def lag(clock_s, stamps, restarted=(NAN, NAN), lost=(False, False)):
    return trailing_s(clock_s, np.array(stamps, dtype=float), np.array(restarted, dtype=float),
                      START_S, np.array(lost))


def test_without_a_clock_nothing_is_known():
    assert math.isnan(lag(None, [START_S, START_S]))


def test_the_slowest_panel_sets_the_lag():
    assert lag(1400.0, [1390.0, 1200.0]) == 200.0


def test_a_panel_never_heard_trails_from_the_start_of_the_day():
    assert lag(1400.0, [1390.0, NAN]) == 400.0


def test_a_restarted_panel_not_heard_yet_trails_from_its_restart():
    # Counted from the start of the day it would trail 400 s, over the 300 s that hold the
    # clock; held, its new loop would run no period and never report.
    assert lag(1400.0, [1400.0, NAN], restarted=(NAN, 1390.0)) == 10.0


def test_once_heard_a_restarted_panel_trails_by_its_state():
    assert lag(1400.0, [1400.0, 1350.0], restarted=(NAN, 1390.0)) == 50.0


def test_lost_panels_are_left_out_and_with_none_left_nothing_trails():
    assert lag(1400.0, [1390.0, NAN], lost=(False, True)) == 10.0
    assert lag(1400.0, [NAN, NAN], lost=(True, True)) == 0.0


def silence(last_status_s, first_states_s, now_s=100.0):
    return silence_s(now_s, last_status_s, np.array(first_states_s, dtype=float))


def test_a_process_is_silent_from_its_last_status():
    assert silence(80.0, [10.0, 20.0]) == 20.0


def test_before_its_first_status_it_is_silent_from_its_panels_first_states():
    # The CI failure: stopped after its panels reported, before its first status, it was
    # never counted as silent, so never killed, and the held clock waited for it for good.
    assert silence(None, [70.0, 84.0]) == 16.0


def test_a_process_still_starting_is_not_silent():
    assert silence(None, [NAN, NAN]) == 0.0
    assert silence(None, [70.0, NAN]) == 0.0
