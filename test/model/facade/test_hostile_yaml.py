"""Hostile facade descriptions: refused fast, within bounded memory, with a short message."""

import os
import subprocess
import sys
import textwrap

import pytest

from flectofold_model import safe_yaml
from flectofold_model.facade.description import build_facade, FacadeError, load_facade

VALID = """
name: test
site: {latitude_deg: 48.78, longitude_deg: 9.18, elevation_m: 245, utc_offset_h: 2}
facade: {azimuth_deg: 180}
surface: {type: plane, width_m: 4.4, height_m: 3.3}
grid: {rows: 3, columns: 4, gap_m: 0.1, midrib_along: v}
panel: {fold_radius_m: 1.0, midrib_end_width_m: 0.04, hinge_width_m: 0.03}
"""
#: Longest message a refusal may print [characters].
MESSAGE_LIMIT = 400


def laughs(levels=10):
    """Anchors of nine aliases each: ``levels`` deep, 9**levels values once expanded."""
    items = ['&l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]']
    items += [f'&l{i} [' + ', '.join([f'*l{i - 1}'] * 9) + ']' for i in range(1, levels)]
    return '[' + ', '.join(items) + ']'


#: A known key whose check quotes the value, and an unknown key.
BOMBS = {'known key': VALID.replace('name: test', f'name: {laughs()}'),
         'unknown key': VALID + f'colour: {laughs()}\n'}
#: Refuse in a child limited to 1 GiB of address space; print the CPU seconds it took and the
#: message, or the failure (CPU time: other work on the machine does not stretch it).
CHILD = textwrap.dedent("""
    import resource, sys, time
    resource.setrlimit(resource.RLIMIT_AS, (2**30, 2**30))
    from flectofold_model.facade.description import build_facade, FacadeError
    started = time.process_time()
    try:
        build_facade(sys.stdin.read())
    except FacadeError as error:
        print(f'{time.process_time() - started:.3f} {error}')
    else:
        print('accepted')
""")


@pytest.mark.parametrize('where', sorted(BOMBS))
def test_billion_laughs_is_refused_fast_in_bounded_memory(where):
    run = subprocess.run([sys.executable, '-c', CHILD], input=BOMBS[where], text=True,
                         capture_output=True, timeout=30,
                         env=dict(os.environ, OPENBLAS_NUM_THREADS='1'))
    assert run.returncode == 0, run.stderr[-2000:]
    took_s, message = run.stdout.split(' ', 1)
    assert float(took_s) < 2.0
    assert 'aliases (*name) are not accepted' in message and 'line ' in message, message
    assert len(message) < MESSAGE_LIMIT


def test_a_huge_scalar_is_refused_by_the_size_bound(tmp_path):
    path = tmp_path / 'huge.yaml'
    path.write_text(VALID.replace('name: test', 'name: ' + 'x' * 50_000_000))
    with pytest.raises(FacadeError, match='longer than') as refused:
        load_facade(path)
    assert str(path) in str(refused.value) and len(str(refused.value)) < MESSAGE_LIMIT
    with pytest.raises(FacadeError, match='longer than'):
        build_facade(VALID + 'name2: ' + 'x' * (safe_yaml.MAX_CHARACTERS + 1))


def test_deep_nesting_is_refused():
    deep = '[' * (safe_yaml.MAX_DEPTH + 5) + ']' * (safe_yaml.MAX_DEPTH + 5)
    with pytest.raises(FacadeError, match='nested deeper than 32 levels'):
        build_facade(VALID + f'overrides: {deep}\n')
    block = ''.join(f'{"  " * level}k{level}:\n' for level in range(safe_yaml.MAX_DEPTH + 1))
    with pytest.raises(FacadeError, match='nested deeper'):
        build_facade(VALID + 'control:\n' + textwrap.indent(block, '  ') + '    x: 1\n')


def test_too_many_nodes_are_refused():
    many = '[' + ', '.join(['0'] * (safe_yaml.MAX_NODES + 1)) + ']'
    with pytest.raises(FacadeError, match=f'more than {safe_yaml.MAX_NODES} YAML nodes'):
        build_facade(VALID + f'overrides: {many}\n')


@pytest.mark.parametrize('replace, message', [
    (('rows: 3', 'rows: ' + 'x' * 1_000_000), 'grid.rows: must be a whole number'),
    (('type: plane', 'type: ' + 'p' * 1_000_000), 'surface.type: must be one of'),
    (('midrib_along: v', 'midrib_along: ' + 'u' * 1_000_000), 'grid.midrib_along'),
    (('azimuth_deg: 180', 'azimuth_deg: [' + ', '.join(['lol'] * 20_000) + ']'),
     'facade.azimuth_deg: must be a number'),
    (('name: test', 'name: {' + ', '.join(f'k{i}: v' for i in range(10_000)) + '}'),
     'name: must be a str'),
])
def test_a_wrong_value_with_a_huge_repr_is_quoted_short(replace, message):
    with pytest.raises(FacadeError, match=message) as refused:
        build_facade(VALID.replace(*replace))
    assert len(str(refused.value)) < MESSAGE_LIMIT and '...' in str(refused.value)


def test_a_huge_unknown_key_is_quoted_short():
    with pytest.raises(FacadeError, match='unknown key') as refused:
        build_facade(VALID + '? ' + 'k' * 1_000_000 + '\n: 1\n')
    assert len(str(refused.value)) < MESSAGE_LIMIT
    with pytest.raises(FacadeError, match='no such panel') as refused:
        build_facade(VALID + 'overrides:\n  ? ' + 'r' * 1_000_000 + '\n  : {}\n')
    assert len(str(refused.value)) < MESSAGE_LIMIT


@pytest.mark.parametrize('number', ['0x' + 'f' * 400_000, '9' * 5000])
def test_numbers_beyond_any_float_are_refused(number):
    with pytest.raises(FacadeError) as refused:
        build_facade(VALID.replace('width_m: 4.4', f'width_m: {number}'))
    assert 'must be finite' in str(refused.value) or 'cannot be read' in str(refused.value)
    assert len(str(refused.value)) < MESSAGE_LIMIT
    with pytest.raises(FacadeError, match='grid.rows: must lie in'):
        build_facade(VALID.replace('rows: 3', 'rows: 0x' + 'f' * 400_000))


@pytest.mark.parametrize('name', ['../../etc/x', 'a/b', '', '.hidden', 'x' * 65, 'a b'])
def test_a_name_that_is_no_plain_word_is_refused(name):
    with pytest.raises(FacadeError, match='name: must be 1 to 64 letters'):
        build_facade(VALID.replace('name: test', f'name: {name!r}'))


def test_malformed_yaml_is_one_line_with_the_place():
    with pytest.raises(FacadeError) as refused:
        build_facade(VALID + 'grid: [1, 2\n')
    message = str(refused.value)
    assert 'malformed YAML: line ' in message and '\n' not in message


def test_a_key_given_twice_is_refused_naming_both_lines(tmp_path):
    # A second latitude_deg, read last-wins, ran a Stuttgart facade at -33 deg with exit 0.
    path = tmp_path / 'twice.yaml'
    text = VALID.replace('site: {', 'site: {latitude_deg: -33.0, ', 1)
    assert text != VALID
    path.write_text(text)
    message = (r"twice.yaml: line \d+, column \d+: key 'latitude_deg' given twice \(first at "
               r'line \d+, column \d+\); one value would silently win')
    with pytest.raises(FacadeError, match=message):
        load_facade(path)


@pytest.mark.parametrize('text, message', [
    ('a: 1\nb: {c: 2, c: 3}\n',
     "line 2, column 11: key 'c' given twice (first at line 2, column 5)"),
    ('- {x: 1}\n- x: 1\n  y: 2\n  x: 3\n',
     "line 4, column 3: key 'x' given twice (first at line 2, column 3)"),
])
def test_twice_given_keys_are_refused_at_any_depth(text, message):
    with pytest.raises(safe_yaml.DuplicateKeyError) as refused:
        safe_yaml.load_yaml(text, 'doc')
    assert str(refused.value) == f'doc: {message}; one value would silently win'


def test_keys_that_differ_in_type_are_two_keys():
    assert safe_yaml.load_yaml("1: a\n'1': b\n") == {1: 'a', '1': 'b'}


def test_python_tags_are_not_constructed():
    with pytest.raises(FacadeError, match='could not determine a constructor'):
        build_facade(VALID.replace('name: test', 'name: !!python/object/apply:os.system [id]'))


def test_short_repr_bounds_any_value():
    nested = [[['x' * 1000] * 1000] * 1000] * 1000  # shared: cheap to build, huge to print
    for value in (nested, 'y' * 10**6, 2**100_000, {'k' * 10**5: nested}, b'z' * 10**6):
        assert len(safe_yaml.short_repr(value)) <= safe_yaml.REPR_LIMIT
    assert safe_yaml.short_repr('north') == "'north'"


def test_read_yaml_reads_a_bounded_prefix(tmp_path):
    path = tmp_path / 'big.yaml'
    path.write_bytes(b'a: ' + b'b' * (safe_yaml.MAX_CHARACTERS + 10))
    with pytest.raises(safe_yaml.YAMLInputError, match='longer than'):
        safe_yaml.read_yaml(path)
    path.write_bytes(b'a: \xff\xfe\n')
    with pytest.raises(safe_yaml.YAMLInputError, match='not UTF-8'):
        safe_yaml.read_yaml(path)
    path.write_text('a: [1, 2]\nb: {c: d}\n')
    assert safe_yaml.read_yaml(path) == {'a': [1, 2], 'b': {'c': 'd'}}
