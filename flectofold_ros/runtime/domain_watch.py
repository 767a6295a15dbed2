"""A node's eye on its ROS domain: another facade's processes, a second source of an input.

Two parts, the rules of both in :mod:`flectofold_ros.wire.presence`:

- :class:`Presence`: the process's announcement on ``/flectofold/instances`` and what it
  hears of others; :meth:`Presence.probe` at start (refuse when another live instance holds
  the same clock, coordinator or panels), :meth:`Presence.announce` once it runs, a callback
  for a conflict that appears while it runs.
- :class:`SourceGuard`: the inputs with one source by design, checked on the graph at every
  message (``count_publishers``) and named in the log when a second publisher comes or goes.
"""

import os
import socket
import time

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.executors import SingleThreadedExecutor

from flectofold_ros.runtime.diagnostics import ERROR
from flectofold_ros.runtime.interfaces import publisher, subscription
from flectofold_ros.wire import contract, presence

#: Wall seconds a process listens at start for the announcements of others, at least (DDS
#: discovery on the loopback takes well under one; a busy machine more) ...
PROBE_S = 2.0
#: ... and at most, while the graph shows an announcing node whose announcement has not come.
PROBE_LIMIT_S = 30.0
#: The graph's node list counts as discovered once it has not changed for this long [s]: longer
#: than Fast DDS's default participant announcement period (3 s), since a participant beyond
#: the others' initial peers (more than four on one host, ``ROS_AUTOMATIC_DISCOVERY_RANGE=
#: LOCALHOST``) may hear of them only at their next announcement.
SETTLED_S = 4.0
#: What announcements are heard with: every live writer's one, up to 100 processes, also
#: when they arrive in a burst before the node is spun.
LISTENING = contract.Qos(depth=100, latched=True)
#: Wall seconds between two looks at the graph.
CHECK_PERIOD_S = 1.0


class Presence:
    """What ``node``'s process announces of itself (``own``), and the live instances it hears.

    ``own`` (a :class:`~flectofold_ros.wire.presence.Instance`) may be set after construction,
    before :meth:`probe`: listening starts at once. ``on_conflict(line)`` is called once per
    instance that holds what this one holds, heard after :meth:`announce`.
    """

    def __init__(self, node, own=None, on_conflict=None):
        self.node, self.own = node, own
        self._key = (socket.gethostname(), os.getpid())
        self.others = {}
        """``(host, pid, role)`` -> :class:`~flectofold_ros.wire.presence.Instance`, heard,
        alive."""
        self.conflicts = []
        """Lines naming the instances in conflict with this one, heard since it announced."""
        self._on_conflict = on_conflict
        self._announced = False
        self._publisher = None
        self._listening_since = time.monotonic()
        self._heard = set()
        self._on_graph = set()
        """Announcing nodes seen on the graph (:meth:`_forget_the_gone`)."""
        """Announcing nodes whose announcement came (this process's own too)."""
        # deeper than the writers' one: announcements of several processes come in a burst
        subscription(node, presence.INSTANCES, self._on_instance, LISTENING)
        node.create_timer(CHECK_PERIOD_S, self._forget_the_gone,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def probe(self, wait_s=PROBE_S, limit_s=PROBE_LIMIT_S):
        # Only a short-lived node of its own is probed (StartCheck): a program's node spun
        # here, then added to the events executor, does not run its ROS-time timers there.
        """Listen, then return the conflict lines.

        From when this object was made: at least ``wait_s``, then on while the graph's node
        list still changes (within SETTLED_S) or lists an announcing node whose announcement
        has not arrived (discovery is slow on a busy machine), at most ``limit_s``. Spins
        ``node`` on a private executor (before the program's own executor takes it).
        """
        executor = SingleThreadedExecutor(context=self.node.context)
        executor.add_node(self.node)
        graph, settled_since = None, time.monotonic()
        try:
            while (now := time.monotonic() - self._listening_since) < limit_s:
                nodes = sorted(self.node.get_node_names_and_namespaces())
                if nodes != graph:
                    graph, settled_since = nodes, time.monotonic()
                if now >= wait_s and time.monotonic() - settled_since >= SETTLED_S and \
                        not self._unheard():
                    break
                executor.spin_once(timeout_sec=0.05)
        finally:
            executor.remove_node(self.node)
            # Its guard conditions now, while the context lives: left to the garbage
            # collector, which may come after rclpy's shutdown, they print "Exception ignored
            # ... InvalidHandle" at exit (a refused start's stderr is then not one line).
            executor.shutdown()
        return presence.conflicts(self.own, self.others.values())

    def _unheard(self):
        """Announcing nodes on the graph whose announcement has not come."""
        own = self.node.get_fully_qualified_name()
        return [name for name in (_full_name(info) for info in
                                  self.node.get_publishers_info_by_topic(presence.INSTANCES.name))
                if name not in self._heard and name != own]

    def announce(self):
        """Announce this process (latched): from now on a conflict heard is reported."""
        name, host, facade, values = self.own.fields()
        self._publisher = publisher(self.node, presence.INSTANCES)
        self._publisher.publish(DiagnosticStatus(
            name=name, hardware_id=host, message=facade,
            values=[KeyValue(key=key, value=value) for key, value in values]))
        self._announced = True
        for line in presence.conflicts(self.own, self.others.values()):
            self._conflict(line)

    def _on_instance(self, message):
        try:
            other = presence.instance_from_fields(
                message.name, message.hardware_id, message.message,
                [(kv.key, kv.value) for kv in message.values])
        except ValueError as error:
            self.node.get_logger().warning(f'ignored an announcement: {error}',
                                           throttle_duration_sec=10.0)
            return
        if other.nodes:
            self._heard.add(other.nodes[0])
        if other.process == self._key:
            return
        self.others[other.key] = other
        if self._announced:
            for line in presence.conflicts(self.own, [other]):
                self._conflict(line)

    def _conflict(self, line):
        if line in self.conflicts:
            return
        self.conflicts.append(line)
        self.node.get_logger().error(f'another facade on this ROS domain: {line}')
        if self._on_conflict is not None:
            self._on_conflict(line)

    def _forget_the_gone(self):
        """Drop instances whose announcing node left the graph (a stopped process).

        Only one seen on the graph before: the graph may learn of a writer after its
        announcement has arrived.
        """
        if not self.others:
            return
        announcing = {_full_name(info) for info in
                      self.node.get_publishers_info_by_topic(presence.INSTANCES.name)}
        self._on_graph |= announcing
        for key, other in list(self.others.items()):
            if other.nodes and other.nodes[0] in self._on_graph - announcing:
                del self.others[key]
                self._on_graph.discard(other.nodes[0])

    def who(self, node_name):
        """Name a node with its host and process when an instance announced it, this one too.

        This process's own nodes (a bringup's coordinator) are named from ``own`` once
        announced: its own announcement is never among ``others``.
        """
        own = [self.own] if self._announced else []
        return presence.who(node_name, [*own, *self.others.values()])


class StartCheck:
    """A short-lived node that listens for other instances from its making to :meth:`refuse`.

    Made early (a process listens while it loads), checked and destroyed before the program's
    own nodes run. ``namespace``/``name``: the node's, ``context`` rclpy's.
    """

    def __init__(self, name, context=None):
        from rclpy.node import Node
        kwargs = {'context': context} if context is not None else {}
        self.node = Node(name, namespace=contract.FACADE_NODE_NAMESPACE,
                         start_parameter_services=False, **kwargs)
        self.presence = Presence(self.node)

    def refuse(self, own):
        """Listen (:meth:`Presence.probe`), destroy the node; ValueError naming a conflict."""
        self.presence.own = own
        try:
            lines = self.presence.probe()
        finally:
            self.node.destroy_node()
        if lines:
            domain = self.node.context.get_domain_id()
            raise ValueError(f'another facade on this ROS domain (ROS_DOMAIN_ID {domain}): '
                             f'{"; ".join(lines)}')


class SourceGuard:
    """Inputs of ``node`` with one source by design: a second publisher noticed and named.

    ``topics`` are contract topic names (each with its policy in
    :data:`~flectofold_ros.wire.presence.ONE_SOURCE`). :meth:`doubled` answers at each message;
    a timer logs each change (ERROR when a second publisher comes, naming every publisher;
    INFO when one is left) and counts the times a second one came.
    """

    def __init__(self, node, topics, who=None):
        self.node, self.topics = node, tuple(topics)
        self._who = who or (lambda name: name)
        self.publishers = {topic: [] for topic in self.topics}
        """Topic -> full names of its publishers while more than one is on it."""
        self.second_publishers = 0
        """Times a second publisher came on one of the topics."""
        self.refused = dict.fromkeys(self.topics, 0)
        """Messages refused (policy ``hold`` or ``storm_only``) because two published."""
        node.create_timer(CHECK_PERIOD_S, self.check,
                          clock=Clock(clock_type=ClockType.STEADY_TIME))

    def doubled(self, topic):
        """Whether more than one publisher is on ``topic`` now (from the graph, cheap)."""
        return self.node.count_publishers(topic) > 1

    def refuse(self, topic):
        """Count a message of ``topic`` refused by its policy; log it once a second."""
        self.refused[topic] += 1
        self.node.get_logger().warning(
            f'refused {topic}: {self.node.count_publishers(topic)} publishers on it '
            f'(policy {presence.ONE_SOURCE[topic]}); see the error naming them',
            throttle_duration_sec=1.0)
        if not self.publishers[topic]:
            self.check()

    def check(self):
        """Look at the graph; log a second publisher's arrival and its leaving."""
        for topic in self.topics:
            names = [_full_name(info) for info in self.node.get_publishers_info_by_topic(topic)]
            if len(names) > 1 and not self.publishers[topic]:
                self.second_publishers += 1
                self.node.get_logger().error(
                    f'{len(names)} publishers on {topic}, which has one by design: '
                    f'{"; ".join(self._who(name) for name in names)}; policy '
                    f'{presence.ONE_SOURCE[topic]}')
            elif len(names) <= 1 and self.publishers[topic]:
                self.node.get_logger().info(f'one publisher on {topic} again')
            self.publishers[topic] = names if len(names) > 1 else []

    def problem(self):
        """Return a line for a status message while an input has two publishers, else ``''``."""
        doubled = [f'{topic} ({len(names)} publishers)'
                   for topic, names in self.publishers.items() if names]
        return f'a second source on {", ".join(doubled)}' if doubled else ''

    def figures(self):
        """``/diagnostics`` figures: second publishers seen, messages refused for them."""
        return {'second_publishers': self.second_publishers,
                'messages_refused_for_two_sources': sum(self.refused.values())}


def report_domain(watch, sources, level, message, figures):
    """Add a status's domain figures; return its level and message, ERROR on a problem.

    ``watch`` is the process's :class:`Presence` (None: the conflicts are another's to
    report), ``sources`` its :class:`SourceGuard`; ``figures`` (a dict) gains their figures.
    """
    figures.update(sources.figures())
    conflicts = watch.conflicts if watch is not None else []
    figures['domain_conflicts'] = '; '.join(conflicts)
    for problem in conflicts[:1] + [sources.problem()]:
        if problem:
            level, message = ERROR, f'{message}; {problem}'
    return level, message


#: Wall seconds a log line waits, at most, for the graph to name a sender it has seen as an
#: endpoint only: DDS discovery gives a writer's endpoint before the ROS graph information that
#: names its node, and a request can come between the two.
NAMING_S = 30.0
#: Wall seconds between two looks at the graph while a sender is unnamed.
NAMING_PERIOD_S = 0.1
#: What rmw reports for a node it knows an endpoint of but not yet its name.
_UNKNOWN_NAME = '_NODE_NAME_UNKNOWN_'


def log_with_senders(node, topic, line, no_mangle=False):
    """Log ``line`` (a warning) followed by `` from`` and the publishers on ``topic``.

    When the graph knows every such publisher's endpoint but not yet its node's name (the
    sender was discovered a moment ago), the line is logged at once with the sender left
    open, and logged again with the name once the graph has it, within :data:`NAMING_S`
    (else a line says it stayed unnamed). ``no_mangle`` passes a raw DDS topic name.
    """
    names = _names(node.get_publishers_info_by_topic(topic, no_mangle=no_mangle))
    if not any(_UNKNOWN_NAME in name for name in names):
        node.get_logger().warning(f'{line} from {_one_line(names)}')
        return
    node.get_logger().warning(f'{line} from a sender the graph has not named yet (named in '
                              f'a following line once discovery gives its name)')
    since_s = time.monotonic()
    timer = None

    def look():
        known = _names(node.get_publishers_info_by_topic(topic, no_mangle=no_mangle))
        waited_s = time.monotonic() - since_s
        if not any(_UNKNOWN_NAME in name for name in known):
            node.get_logger().warning(
                f'{line} from {_one_line(known)} (named {waited_s:.1f} s later)')
        elif waited_s > NAMING_S:
            node.get_logger().warning(
                f'{line}: its sender still unnamed after {NAMING_S:.0f} s ({_one_line(known)})')
        else:
            return
        node.destroy_timer(timer)

    timer = node.create_timer(NAMING_PERIOD_S, look,
                              clock=Clock(clock_type=ClockType.STEADY_TIME))


def log_with_service_clients(node, service_name, line):
    """Log ``line`` followed by `` from`` and the clients of ``service_name``.

    A service's request is a message on ``rq/<name>Request``; rclpy gives a service callback
    no sender, so this names every client on it, as :func:`log_with_senders` does.
    """
    log_with_senders(node, f'rq{service_name}Request', line, no_mangle=True)


def _names(infos):
    return sorted({_full_name(info) for info in infos})


def _one_line(names):
    if not names:
        return 'a sender gone from the graph'
    if len(names) == 1:
        return names[0]
    return f'one of {presence.quoted(names)}'


def _full_name(info):
    namespace = info.node_namespace.rstrip('/')
    return f'{namespace}/{info.node_name}'
