"""Parameters of the package's nodes: each with a default, a description, a type and a range.

A node lists its parameters as ``{name: Spec}`` built with :func:`double`, :func:`integer`,
:func:`choice`, :func:`string`, :func:`strings` or :func:`boolean`, and declares them with
:func:`declare_all`. rclpy checks types and numeric ranges on declare and on every set; the
choices of a :func:`choice` are checked here, at start (a ``ValueError`` naming the parameter)
and on every runtime set (a refused set with the reason), so that nothing parses choices
back out of description text. A node's own runtime checks go in an ``on_set`` callback and
its reaction to accepted changes in a ``post_set`` one.
"""

from dataclasses import dataclass

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)


@dataclass(frozen=True)
class Spec:
    """One parameter: default value, descriptor, and for a choice the allowed values."""

    default: object
    descriptor: ParameterDescriptor
    choices: tuple = ()

    @property
    def read_only(self):
        return self.descriptor.read_only


def double(default, description, low, high, read_only=True):
    """Describe a double parameter that rclpy range-checks on declare and on every set."""
    return Spec(float(default), ParameterDescriptor(
        type=ParameterType.PARAMETER_DOUBLE, description=description, read_only=read_only,
        floating_point_range=[FloatingPointRange(from_value=low, to_value=high)]))


def integer(default, description, low, high, read_only=True):
    """Describe an integer parameter that rclpy range-checks on declare and every set."""
    return Spec(int(default), ParameterDescriptor(
        type=ParameterType.PARAMETER_INTEGER, description=description, read_only=read_only,
        integer_range=[IntegerRange(from_value=low, to_value=high, step=1)]))


def choice(default, description, choices, read_only=True):
    """Describe a string parameter that must be one of ``choices``."""
    choices = tuple(choices)
    if default not in choices:
        raise ValueError(f'default {default!r} is not one of {choices}')
    return Spec(default, ParameterDescriptor(
        type=ParameterType.PARAMETER_STRING, description=description, read_only=read_only,
        additional_constraints=f'one of: {", ".join(choices)}'), choices)


def string(default, description, read_only=True, constraints=''):
    """Describe a string parameter; ``constraints`` tells users what it takes."""
    return Spec(default, ParameterDescriptor(
        type=ParameterType.PARAMETER_STRING, description=description, read_only=read_only,
        additional_constraints=constraints))


def strings(default, description, read_only=True, constraints=''):
    """Describe a string-array parameter."""
    return Spec(list(default), ParameterDescriptor(
        type=ParameterType.PARAMETER_STRING_ARRAY, description=description,
        read_only=read_only, additional_constraints=constraints))


def boolean(default, description, read_only=True):
    """Describe a bool parameter."""
    return Spec(bool(default), ParameterDescriptor(
        type=ParameterType.PARAMETER_BOOL, description=description, read_only=read_only))


def declare_all(node, specs):
    """Declare ``{name: Spec}`` on ``node`` and hold every choice to its allowed values.

    Raises ``ValueError`` naming the parameter if a given value is not one of its choices,
    and installs an ``on_set`` callback that refuses such a value at run time.
    """
    for name, spec in specs.items():
        node.declare_parameter(name, spec.default, spec.descriptor)
    for name, spec in specs.items():
        problem = choice_problem(name, node.get_parameter(name).value, specs)
        if problem:
            raise ValueError(problem)
    node.add_on_set_parameters_callback(lambda parameters: _check_choices(parameters, specs))


def choice_problem(name, value, specs):
    """Why ``value`` is not a valid choice of parameter ``name``, or None if it is (or free)."""
    spec = specs.get(name)
    if spec is None or not spec.choices or value in spec.choices:
        return None
    return f'parameter {name}={value!r} must be one of {", ".join(spec.choices)}'


def _check_choices(parameters, specs):
    for parameter in parameters:
        problem = choice_problem(parameter.name, parameter.value, specs)
        if problem:
            return SetParametersResult(successful=False, reason=problem)
    return SetParametersResult(successful=True)


def values(node, specs):
    """``{name: value}`` of every parameter in ``specs``, as ``node`` holds them now."""
    return {name: node.get_parameter(name).value for name in specs}


def usage_lines(usage, specs):
    """``--help`` text: the usage line, then every parameter with default, range and meaning."""
    lines = [f'usage: {usage}', '', 'parameters (--ros-args -p name:=value):']
    for name, spec in specs.items():
        descriptor = spec.descriptor
        ranges = [f'[{r.from_value:g}, {r.to_value:g}]'
                  for r in (*descriptor.floating_point_range, *descriptor.integer_range)]
        extra = ' '.join(ranges + [descriptor.additional_constraints]).strip()
        lines.append(f'  {name} (default {spec.default!r}{", " + extra if extra else ""}'
                     f'{", read-only" if descriptor.read_only else ""}): '
                     f'{descriptor.description}')
    return lines
