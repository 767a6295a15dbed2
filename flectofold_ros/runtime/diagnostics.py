"""REP-107 diagnostics of the package's nodes, built one way.

Every node reports one ``DiagnosticStatus`` per component on ``/diagnostics``, named
``<node's full name>: <component>``, with its figures as ``KeyValue`` text (floats with 12
significant digits, enough for a POSIX time to the microsecond).
"""

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR


def status(node, level, component, hardware_id, message, figures):
    """One ``DiagnosticStatus`` of ``node``'s ``component`` with ``figures`` as key/values."""
    return DiagnosticStatus(
        level=level, name=f'{node.get_fully_qualified_name()}: {component}',
        hardware_id=hardware_id, message=message,
        values=[KeyValue(key=key, value=_text(value)) for key, value in figures.items()])


def diagnostic_array(node, statuses):
    """Return a ``DiagnosticArray`` of ``statuses`` stamped with ``node``'s clock now."""
    array = DiagnosticArray(status=list(statuses))
    array.header.stamp = node.get_clock().now().to_msg()
    return array


def _text(value):
    return f'{value:.12g}' if isinstance(value, float) else str(value)
