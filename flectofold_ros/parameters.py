"""Parameter descriptors of the package's nodes: every parameter with a description and range."""

from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor, ParameterType


def double(description, low, high, read_only=True):
    """Describe a double parameter that rclpy range-checks on declare and on every set."""
    return ParameterDescriptor(
        type=ParameterType.PARAMETER_DOUBLE, description=description, read_only=read_only,
        floating_point_range=[FloatingPointRange(from_value=low, to_value=high)])


def string(description, read_only=True, constraints=''):
    """Describe a string parameter; ``constraints`` is shown to users (e.g. the choices)."""
    return ParameterDescriptor(type=ParameterType.PARAMETER_STRING, description=description,
                               read_only=read_only, additional_constraints=constraints)


def declare_all(node, parameters):
    """Declare ``{name: (default, descriptor)}`` on ``node``."""
    for name, (default, descriptor) in parameters.items():
        node.declare_parameter(name, default, descriptor)


def boolean(description, read_only=True):
    """Describe a bool parameter."""
    return ParameterDescriptor(type=ParameterType.PARAMETER_BOOL, description=description,
                               read_only=read_only)


def strings(description, read_only=True, constraints=''):
    """Describe a string-array parameter."""
    return ParameterDescriptor(type=ParameterType.PARAMETER_STRING_ARRAY,
                               description=description, read_only=read_only,
                               additional_constraints=constraints)
