"""A bringup that ends badly: killed with SIGKILL, or its recorder's disk full.

Its children die with it (no orphan stays on the domain, the bag is complete); a recorder whose
disk has no room is not restarted onto it, and the summary says what was not recorded. Split
from ``test_supervision.py`` so that these long days run beside its others, not after them.
"""

import os
import signal
import subprocess
import time

from bringup_day import end_day, start_day
from process_state import running
import pytest
from ros_graph import domain_for, Graph
from rosbags.rosbag2 import Reader
import yaml

pytestmark = pytest.mark.graph


def test_a_bringup_killed_with_sigkill_leaves_no_child_running_and_a_complete_bag(
        small_facade_file, tmp_path):
    # Before, its panel processes, recorder and bridge ran on as orphans (still there after
    # 60 s), holding the bag's lock, and would mix into the next run on the domain.
    graph, children = Graph(domain_for(59)), []
    try:
        bringup, output = start_day(graph, small_facade_file, '11:40', '--panel-processes', '2',
                                    '--record', '--rerun', 'none', '--out', str(tmp_path / 'out'))
        children = [int(pid) for pid in subprocess.run(
            ['pgrep', '-P', str(bringup.pid)], capture_output=True, text=True).stdout.split()]
        assert len(children) == 4, children  # two panel processes, the recorder, the bridge
        graph.spin_for(2.0)  # the recorder writes a little of the day
        subprocess.run(['kill', '-KILL', str(bringup.pid)], check=True)
        bringup.wait(timeout=30)
        deadline = time.monotonic() + 60.0
        while any(running(pid) for pid in children) and time.monotonic() < deadline:
            time.sleep(0.2)
        survivors = [pid for pid in children if running(pid)]
    finally:
        for pid in children:
            if running(pid):  # orphans of a failure would mix into the next test's domain
                os.kill(pid, signal.SIGKILL)
        graph.close()
    assert survivors == [], survivors
    run = next((tmp_path / 'out').glob('2026-*'))
    metadata = yaml.safe_load((run / 'bag' / 'metadata.yaml').read_text())
    assert metadata['rosbag2_bagfile_information']['message_count'] > 0
    with Reader(run / 'bag') as reader:  # the recorder closed it on its SIGTERM
        assert reader.message_count == sum(1 for _ in reader.messages()) > 0


@pytest.fixture
def full_disk(tmp_path):
    """Mount a 200 KiB tmpfs: a disk that fills in the first half of a 40-minute day."""
    mount_point = tmp_path / 'small_disk'
    mount_point.mkdir()
    mounted = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=200k', 'tmpfs',
                              str(mount_point)], capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f'a small disk is mounted as tmpfs, which needs the right to mount here: '
                    f'{mounted.stderr.strip()}')
    yield mount_point
    subprocess.run(['umount', '-l', str(mount_point)], check=False)


def test_a_recorder_whose_disk_is_full_is_not_restarted_and_the_summary_says_what_is_missing(
        small_facade_file, full_disk):
    # Before, it was restarted onto the same full disk, and the rest of the day went
    # unrecorded with exit 0.
    graph = Graph(domain_for(61))
    try:
        bringup, output = start_day(graph, small_facade_file, '11:40', '--panel-processes', '1',
                                    '--record', '--out', str(full_disk))
        assert output.wait_for(graph, 'not restarted: its disk has no room', 120), output.text
        end_day(graph, bringup, output, 120)
    finally:
        graph.close()
    text = output.text
    assert bringup.returncode == 3, text  # a child lost for good
    assert 'bag_recorder (pid' in text and 'died: exit 4; not restarted' in text
    assert 'restarted (pid' not in text
    assert '  NOT RECORDED: from 11:' in text and ' to 11:40 (local): the recorder stopped, ' \
        'its disk' in text and 'has no room; it was not restarted onto it' in text, text
