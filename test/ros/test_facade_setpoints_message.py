"""``/facade/setpoints`` read and written without ROS (``wire.facade_setpoints``)."""

import math

import pytest

from flectofold_ros.wire.facade_setpoints import entries, fields, SetpointsMessageError


def test_entries_pair_names_with_closures_and_refuse_what_does_not_pair():
    assert entries(['r00c00', 'r00c01'], [0.2, 0.4]) == [('r00c00', 0.2), ('r00c01', 0.4)]
    assert math.isnan(entries(['r00c00'], [math.nan])[0][1])  # the guard's to refuse
    with pytest.raises(SetpointsMessageError, match='1 name.*2 position'):
        entries(['r00c00'], [0.2, 0.4])
    with pytest.raises(SetpointsMessageError, match='r00c00 named more than once'):
        entries(['r00c00', 'r00c01', 'r00c00'], [0.2, 0.4, 0.6])
    assert fields(['r00c00'], [1]) == (['r00c00'], [1.0])
    with pytest.raises(ValueError, match='1 closure.*2 panel'):
        fields(['r00c00', 'r00c01'], [0.5])
