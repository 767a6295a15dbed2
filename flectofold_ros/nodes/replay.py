"""Node ``replay``: a recorded bag played back onto the graph, with its ``/clock``.

The ``replay`` command (:mod:`flectofold_ros.commands.replay`) runs it unless asked for
``--to-rrd``; the bag's messages go out as recorded (serialized bytes), at their recorded
spacing divided by ``--rate``. Contract: ``msg_docs/replay.md``.
"""

import time

from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node

from flectofold_ros.recording import (bag_topics, BagError, read_messages,
                                      require_topics)
from flectofold_ros.runtime.interfaces import publisher
from flectofold_ros.runtime.runner import Program, run_nodes
from flectofold_ros.wire import contract

#: Wall seconds between the player's looks for messages that are due.
PLAY_PERIOD_S = 0.01
#: Wall seconds one look may publish for before it hands back to the executor, which sees a
#: stop signal only between callbacks (a fast ``--rate`` makes a whole bag due at once).
PLAY_BUDGET_S = 0.05
#: Wall seconds the new publishers get to match their subscribers before the first message:
#: at least the first, then until every topic has a subscriber, at most the second (a topic
#: nobody listens to must not hold the others back for long).
MATCH_S, MATCH_MAX_S = 0.5, 3.0


class Player(Node):
    """Publishes a bag's messages when their time, scaled by ``options.rate``, is due."""

    def __init__(self, options, topics, selected):
        super().__init__(contract.REPLAY_NODE)
        self.options, self.selected = options, selected
        self.publishers_ = {
            topic: publisher(self, contract.Topic(
                topic, topics[topic][0],
                contract.LATCHED if topics[topic][1] else contract.REPLAY))
            for topic in selected}
        self.published, self.passes, self.finished = 0, 0, False
        self._messages, self._pending = None, None
        self._started, self._first_ns = None, None
        self._created = time.monotonic()
        self.create_timer(PLAY_PERIOD_S, self._play, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _play(self):
        if self.finished or not self._matched():
            return
        if self._messages is None:
            self._messages = read_messages(self.options.bag, self.selected,
                                           self.options.skip_unreadable)
            self._started, self._first_ns = time.monotonic(), None
        budget_end = time.monotonic() + PLAY_BUDGET_S
        while time.monotonic() < budget_end:
            if self._pending is None:
                self._pending = next(self._messages, None)
                if self._pending is None:
                    self._end_of_pass()
                    return
            topic, _, t_ns, raw = self._pending
            if self._first_ns is None:
                self._first_ns = t_ns
            due = self._started + (t_ns - self._first_ns) * 1e-9 / self.options.rate
            if time.monotonic() < due:
                return
            self.publishers_[topic].publish(raw)
            self.published += 1
            self._pending = None

    def _matched(self):
        waited = time.monotonic() - self._created
        if self._messages is not None or waited >= MATCH_MAX_S:
            return True
        return waited >= MATCH_S and all(p.get_subscription_count() > 0
                                         for p in self.publishers_.values())

    def _end_of_pass(self):
        self.passes += 1
        self._messages = None
        self.finished = not self.options.loop

    def wait_for_acks(self):
        """Let reliable subscribers take the last messages (up to 2 s per publisher)."""
        for topic_publisher in self.publishers_.values():
            topic_publisher.wait_for_all_acked(Duration(seconds=2.0))


class Playing(Program):
    """The player as a program: done after its last pass; on close, the figures."""

    def __init__(self, options, topics, selected):
        super().__init__([Player(options, topics, selected)])

    def done(self):
        return self.nodes[0].finished

    def close(self, interrupted):
        player = self.nodes[0]
        if not interrupted:
            player.wait_for_acks()
        print(f'replay: {player.published} messages published, {player.passes} pass(es) of '
              f'{player.options.bag}', flush=True)


def play(options, args):
    """Publish the bag's messages with their recorded spacing; return the exit code."""
    def start():
        topics = bag_topics(options.bag, options.skip_unreadable)
        selected = options.topics or sorted(topics)
        require_topics(options.bag, topics, selected)  # before anything joins the graph
        return Playing(options, topics, selected)

    return run_nodes('replay', args, start, bad_input=(BagError,))
