"""One REP-107 diagnostics message from a node's figures."""

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue


def diagnostic_array(node, level, what, hardware_id, message, figures):
    """Return a ``DiagnosticArray`` stamped now with one status named ``<node>: <what>``.

    ``figures`` maps keys to numbers or text; floats are written with 6 significant digits.
    """
    array = DiagnosticArray()
    array.header.stamp = node.get_clock().now().to_msg()
    array.status.append(DiagnosticStatus(
        level=level, name=f'{node.get_fully_qualified_name()}: {what}',
        hardware_id=hardware_id, message=message,
        values=[KeyValue(key=k, value=f'{v:.6g}' if isinstance(v, float) else str(v))
                for k, v in figures.items()]))
    return array
