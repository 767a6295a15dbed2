"""The bringup tests' facade: 2 x 2 panels, supervised as a day of the bringup runs them."""

from bringup_day import supervised_facade_file
import pytest


@pytest.fixture()
def small_facade_file(small_facade_text, tmp_path):
    return supervised_facade_file(small_facade_text, tmp_path)
