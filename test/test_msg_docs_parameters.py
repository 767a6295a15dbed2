"""The parameter tables of msg_docs/ held to the nodes' parameter specs (issue 30).

Every node declares its parameters from ``{name: Spec}`` (``flectofold_ros.runtime.parameters``);
its page has a markdown table of them, written by hand. This file reads each page's table (the
one whose header starts with ``parameter`` or ``name`` and has a ``default`` column) and holds
it to the specs: one row per parameter and no other (besides rclpy's own ``use_sim_time``),
and the type, default, range or choices and read-only flag of each row as the spec has them, in
whichever of the columns ``type``, ``default``, ``range`` and ``runtime`` the table has. A
table without a ``runtime`` column says ``All are read-only`` just below it. The ``meaning``
column is prose and not compared.

How a cell is read:

* type: ``string``, ``double``, ``integer``, ``bool`` or ``string[]``;
* default: a string in backticks (```''``` for the empty one, a remark may follow), a double
  written as a float (``16.0``, not ``16``, as ``-p`` wants it), an integer, ``true`` or
  ``false``; a string array as backticked items, or the backticked name of the constant that
  holds them, as the node's module sees it (```contract.RECORDED_BY_DEFAULT```);
* range: ``[low, high]`` (a remark may follow) for numbers; the backticked choices of a
  choice; for a free string, prose that must not read as a closed list of choices; empty for
  a bool;
* runtime: ``read-only`` or ``settable``.
"""

import importlib
from itertools import zip_longest
from pathlib import Path
import re

import pytest
from rcl_interfaces.msg import ParameterType

from flectofold_ros.runtime.parameters import Spec

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / 'flectofold_ros'
MSG_DOCS = ROOT / 'msg_docs'

#: Module of each node with a parameter spec dict -> its page in msg_docs/.
PAGES = {
    'flectofold_ros.nodes.panel': 'panel_node.md',
    'flectofold_ros.nodes.coordinator': 'coordinator_node.md',
    'flectofold_ros.nodes.sun_position': 'sun_position.md',
    'flectofold_ros.nodes.weather': 'weather.md',
    'flectofold_ros.nodes.bag_recorder': 'bag_recorder.md',
    'flectofold_ros.nodes.rerun_bridge': 'rerun_bridge.md',
    'flectofold_ros.nodes.facade_markers': 'markers.md',
    'flectofold_ros.nodes.bacnet_gateway': 'bacnet_gateway.md',
}
#: Parameters rclpy declares on every node that a page may list: name -> (type, default).
RCLPY_OWN = {'use_sim_time': ('bool', False)}
TYPE_WORDS = {
    ParameterType.PARAMETER_STRING: 'string',
    ParameterType.PARAMETER_DOUBLE: 'double',
    ParameterType.PARAMETER_INTEGER: 'integer',
    ParameterType.PARAMETER_BOOL: 'bool',
    ParameterType.PARAMETER_STRING_ARRAY: 'string[]',
}
ALL_READ_ONLY = 'All are read-only'
CODE = re.compile(r'`([^`]*)`')
RANGE = re.compile(r'\[\s*([^,\]\s]+)\s*,\s*([^\]\s]+)\s*\]')
FLOAT_LITERAL = re.compile(r'-?(\d+\.\d*|\d*\.\d+|\d+(\.\d*)?[eE][-+]?\d+)')


def specs_of(module):
    """Return the node's ``{name: Spec}``, by its module attribute ``PARAMETERS``."""
    return importlib.import_module(module).PARAMETERS


def cells(line):
    r"""Split a table row into cells at the pipes outside code spans (``\|`` is a pipe)."""
    text = line.strip()
    text = text[1:] if text.startswith('|') else text
    text = text[:-1] if text.endswith('|') and not text.endswith('\\|') else text
    row, cell, code, index = [], '', False, 0
    while index < len(text):
        char = text[index]
        if char == '\\' and text[index + 1:index + 2] == '|' and not code:
            cell, index = cell + '|', index + 2
            continue
        if char == '`':
            code = not code
        if char == '|' and not code:
            row.append(cell.strip())
            cell = ''
        else:
            cell += char
        index += 1
    return row + [cell.strip()]


def tables(text):
    """``(header, rows, paragraph after)`` of every table of a markdown page."""
    lines = text.splitlines()
    found, index = [], 0
    while index < len(lines):
        if not (lines[index].lstrip().startswith('|') and index + 1 < len(lines)
                and re.fullmatch(r'\s*\|?[\s:|-]*-[\s:|-]*', lines[index + 1])):
            index += 1
            continue
        header = [cell.lower() for cell in cells(lines[index])]
        index += 2
        rows = []
        while index < len(lines) and lines[index].lstrip().startswith('|'):
            # A missing cell reads as empty; extra ones go under the key None.
            rows.append(dict(zip_longest(header, cells(lines[index]), fillvalue='')))
            index += 1
        while index < len(lines) and not lines[index].strip():
            index += 1
        after = []
        while index < len(lines) and lines[index].strip():
            after.append(lines[index].strip())
            index += 1
        found.append((header, rows, ' '.join(after)))
    return found


def parameter_table(text):
    """``(header, rows, paragraph after)`` of the page's one parameter table."""
    found = [table for table in tables(text)
             if table[0][0] in ('parameter', 'name') and 'default' in table[0]]
    assert len(found) == 1, f'{len(found)} parameter tables (one wanted)'
    return found[0]


def row_name(row, header):
    match = re.fullmatch(r'`([^`]+)`', row[header[0]])
    return match.group(1) if match else row[header[0]]


def row_problems(text, specs):
    """List what keeps the rows of the page's table from being exactly the spec'd ones."""
    header, rows, _ = parameter_table(text)
    names = [row_name(row, header) for row in rows]
    problems = [f'{name}: {names.count(name)} rows' for name in sorted(set(names))
                if names.count(name) > 1]
    problems += [f"{name}: spec'd but has no row" for name in specs if name not in names]
    problems += [f'{name}: a row, but no parameter of the node' for name in names
                 if name not in specs and name not in RCLPY_OWN]
    problems += [f'{row[header[0]]}: the name is not in backticks' for row in rows
                 if not re.fullmatch(r'`[^`]+`', row[header[0]])]
    problems += [f'{row[header[0]]}: more cells than the header has' for row in rows
                 if None in row]
    return problems


def documented_default(cell, kind, namespace):
    """Read the value a default cell gives a parameter of type ``kind``; ValueError if none."""
    spans = CODE.findall(cell)
    if kind == 'string':
        if not cell.startswith('`'):
            raise ValueError('a string default is written in backticks')
        return '' if spans[0] == "''" else spans[0]
    if kind == 'double':
        if not FLOAT_LITERAL.fullmatch(cell):
            raise ValueError('a double default is written as a float (as -p wants it)')
        return float(cell)
    if kind == 'integer':
        return int(cell)
    if kind == 'bool':
        return {'true': True, 'false': False}[cell]
    if len(spans) == 1 and re.fullmatch(r'[A-Za-z_]\w*(\.[A-Za-z_]\w*)+', spans[0]):
        first, *rest = spans[0].split('.')
        value = namespace[first]
        for attribute in rest:
            value = getattr(value, attribute)
        return list(value)
    return spans


def range_problem(cell, spec, kind):
    """Why a range cell does not give the spec's range or choices, or None."""
    descriptor = spec.descriptor
    if kind in ('double', 'integer'):
        (bounds,) = (*descriptor.floating_point_range, *descriptor.integer_range)
        match = RANGE.match(cell)
        if not match:
            return f'range {cell!r} is not [low, high]'
        low, high = (float(end) for end in match.groups())
        if (low, high) != (bounds.from_value, bounds.to_value):
            return (f'range [{match.group(1)}, {match.group(2)}], spec '
                    f'[{bounds.from_value:g}, {bounds.to_value:g}]')
        return None
    spans = CODE.findall(cell)
    closed = bool(spans) and not re.sub(r'[\s,]+|\bor\b|\band\b', '', CODE.sub('', cell))
    if spec.choices:
        if not closed or sorted(spans) != sorted(spec.choices):
            return f'choices {cell!r}, spec {", ".join(spec.choices)}'
        return None
    if kind == 'bool' and cell:
        return f'range {cell!r} for a bool'
    if closed or RANGE.match(cell):
        return f'range {cell!r} reads as a constraint the spec does not make'
    return None


def value_problems(text, specs, namespace):
    """Where a row's type, default, range or runtime cell disagrees with the spec."""
    header, rows, after = parameter_table(text)
    problems = []
    if 'runtime' not in header:
        if not after.startswith(ALL_READ_ONLY):
            problems.append(f'no runtime column, and the table is not followed by '
                            f'"{ALL_READ_ONLY}"')
        problems += [f'{name}: settable, but the page says all are read-only'
                     for name, spec in specs.items() if not spec.read_only]
    for row in rows:
        name = row_name(row, header)
        if name in RCLPY_OWN and name not in specs:
            kind, default = RCLPY_OWN[name]
            written = str(default).lower()
            if row.get('type', kind) != kind or row.get('default', written) != written:
                problems.append(f"{name}: rclpy's own is a {kind} with default {written}")
            continue
        if name not in specs:
            continue
        spec = specs[name]
        kind = TYPE_WORDS[spec.descriptor.type]
        if 'type' in header and row['type'] != kind:
            problems.append(f'{name}: type {row["type"]!r}, spec {kind}')
        if 'default' in header:
            try:
                default = documented_default(row['default'], kind, namespace)
            except (ValueError, KeyError, IndexError, AttributeError) as error:
                problems.append(f'{name}: default {row["default"]!r} unreadable: {error}')
            else:
                if default != spec.default:
                    problems.append(f'{name}: default {row["default"]!r}, spec '
                                    f'{spec.default!r}')
        if 'range' in header:
            problem = range_problem(row['range'], spec, kind)
            if problem:
                problems.append(f'{name}: {problem}')
        if 'runtime' in header:
            runtime = 'read-only' if spec.read_only else 'settable'
            if row['runtime'] != runtime:
                problems.append(f'{name}: runtime {row["runtime"]!r}, spec {runtime}')
    return problems


def page_text(page):
    return (MSG_DOCS / page).read_text(encoding='utf-8')


def namespace_of(module):
    return vars(importlib.import_module(module))


def spec_dicts(module):
    """Every module-level ``{name: Spec}`` of ``module``."""
    return [value for value in vars(importlib.import_module(module)).values()
            if isinstance(value, dict) and value
            and all(isinstance(spec, Spec) for spec in value.values())]


def with_cell(text, name, column, value):
    """``text`` with the ``column`` cell of parameter ``name``'s row set to ``value``."""
    header, _, _ = parameter_table(text)
    lines = text.splitlines()
    for index, line in enumerate(lines):
        row = cells(line) if line.lstrip().startswith('|') else []
        if row and row[0] == f'`{name}`' and len(row) == len(header):
            row[header.index(column)] = value
            lines[index] = '| ' + ' | '.join(row) + ' |'
            return '\n'.join(lines) + '\n'
    raise AssertionError(f'no row {name}')


@pytest.mark.parametrize('module', PAGES, ids=PAGES.values())
def test_every_parameter_has_a_row_in_its_page_and_every_row_is_a_parameter(module):
    problems = row_problems(page_text(PAGES[module]), specs_of(module))
    assert not problems, f'msg_docs/{PAGES[module]}:\n' + '\n'.join(problems)


@pytest.mark.parametrize('module', PAGES, ids=PAGES.values())
def test_type_default_range_and_runtime_of_every_row_agree_with_the_spec(module):
    problems = value_problems(page_text(PAGES[module]), specs_of(module), namespace_of(module))
    assert not problems, f'msg_docs/{PAGES[module]}:\n' + '\n'.join(problems)


def test_every_module_that_declares_parameters_has_its_specs_in_a_checked_page():
    declaring = sorted(
        '.'.join(path.relative_to(ROOT).with_suffix('').parts)
        for path in PACKAGE.rglob('*.py')
        if 'declare_all(' in path.read_text(encoding='utf-8')
        and path != PACKAGE / 'runtime' / 'parameters.py')
    assert declaring, 'no module calls declare_all: has it been renamed?'
    documented = [specs_of(module) for module in PAGES]
    unchecked = [
        f'{module}: {sorted(specs)}' for module in declaring for specs in spec_dicts(module)
        if not any(all(checked.get(name) is spec for name, spec in specs.items())
                   for checked in documented)]
    assert not unchecked, ('spec dicts no page is checked against (add them to PAGES):\n'
                           + '\n'.join(unchecked))
    unseen = [module for module in declaring if not spec_dicts(module)]
    assert not unseen, f'declare_all with no module-level spec dict in sight: {unseen}'


def test_the_default_topics_bag_recorder_md_lists_below_its_table_are_those_recorded():
    module = 'flectofold_ros.nodes.bag_recorder'
    (paragraph,) = [paragraph for paragraph in page_text(PAGES[module]).split('\n\n')
                    if paragraph.startswith('The default `topics`')]
    listed = [span for span in CODE.findall(paragraph) if span.startswith('/')]
    assert listed == specs_of(module)['topics'].default


def added_problems(module, edit):
    """Problems ``edit`` (page text -> page text) adds to the module's page, rows and values.

    Those of the page as it is are left out, so that these tests of the checks do not fail
    with a page that disagrees on something else (the tests above report that).
    """
    specs, namespace, text = specs_of(module), namespace_of(module), page_text(PAGES[module])

    def found(page):
        return row_problems(page, specs) + value_problems(page, specs, namespace)
    before = found(text)
    return [problem for problem in found(edit(text)) if problem not in before]


@pytest.mark.parametrize('column, value, expected', [
    ('default', '0.2', "control_period_s: default '0.2', spec 0.1"),
    ('default', '1', "control_period_s: default '1' unreadable"),
    ('range', '[0.01, 2]', 'control_period_s: range [0.01, 2], spec [0.01, 1]'),
    ('type', 'integer', "control_period_s: type 'integer', spec double"),
    ('runtime', 'settable', "control_period_s: runtime 'settable', spec read-only"),
], ids=['default', 'int_for_a_double', 'range', 'type', 'runtime'])
def test_a_row_that_disagrees_with_the_spec_is_reported(column, value, expected):
    problems = added_problems('flectofold_ros.nodes.panel', lambda text: with_cell(
        text, 'control_period_s', column, value))
    assert len(problems) == 1 and problems[0].startswith(expected), problems


@pytest.mark.parametrize('name, value, expected', [
    ('hardware', '`simulated`, `real`', 'hardware: choices'),
    ('modbus.host', '`127.0.0.1`, `::1`', 'modbus.host: range'),
], ids=['other_choices', 'choices_of_a_free_string'])
def test_choices_that_are_not_the_spec_ones_are_reported(name, value, expected):
    problems = added_problems('flectofold_ros.nodes.panel', lambda text: with_cell(
        text, name, 'range', value))
    assert len(problems) == 1 and problems[0].startswith(expected), problems


def test_a_missing_row_and_a_row_of_no_parameter_are_reported():
    problems = added_problems('flectofold_ros.nodes.panel', lambda text: text.replace(
        '| `heartbeat_period_s` |', '| `heartbeat_s` |'))
    assert problems == ["heartbeat_period_s: spec'd but has no row",
                        'heartbeat_s: a row, but no parameter of the node']


def test_a_table_without_a_runtime_column_must_say_all_are_read_only():
    problems = added_problems('flectofold_ros.nodes.coordinator', lambda text: text.replace(
        ALL_READ_ONLY, 'Most are read-only'))
    assert problems == [f'no runtime column, and the table is not followed by '
                        f'"{ALL_READ_ONLY}"']
