"""YAML from users and files, read within bounds: no aliases, limited size, nodes and depth.

``yaml.safe_load`` builds no objects but the plain ones, yet it still trusts the document's
shape: an anchor referenced by aliases that reference it again (a "billion laughs" document)
is a few hundred bytes that stand for billions of values, and whatever walks or formats the
loaded value (a ``repr`` in an error message) expands them all. :func:`load_yaml` refuses every
alias, naming its line and column, and refuses a document longer than :data:`MAX_CHARACTERS`,
with more than :data:`MAX_NODES` nodes or nested deeper than :data:`MAX_DEPTH`, before it is
built; a mapping that gives a key twice is refused naming both lines (PyYAML would keep the
last value without a word). :func:`read_yaml` reads at most one character more than the bound
from a file. A reader with rules of its own asks :func:`load_yaml` for them: a smaller size
bound, anchors refused as well as aliases, decimal numbers only (``12:30`` read as text).
:func:`short_repr` quotes a value in an error message in at most a line.

No rclpy: the model, the nodes and the recorder's readers share it.
"""

import re
import reprlib
from typing import Any, Optional

import yaml
from yaml.composer import Composer
from yaml.constructor import SafeConstructor
from yaml.error import Mark
from yaml.events import AliasEvent
from yaml.nodes import MappingNode, Node, ScalarNode
from yaml.resolver import Resolver

from flectofold_model._validate import PathLike

try:  # libyaml's parser when the wheel has it (fast); composing stays here, bounded
    from yaml.cyaml import CParser as _Parser
except ImportError:  # pragma: no cover - the pure-Python parser of the same events
    from yaml.parser import Parser
    from yaml.reader import Reader
    from yaml.scanner import Scanner

    class _Parser(Reader, Scanner, Parser):  # type: ignore[no-redef]
        def __init__(self, stream: str) -> None:
            Reader.__init__(self, stream)
            Scanner.__init__(self)
            Parser.__init__(self)

#: Longest document accepted [characters]: a facade description is a few kilobytes.
MAX_CHARACTERS = 4 * 2**20
#: Most scalars, sequences and mappings in a document.
MAX_NODES = 100_000
#: Deepest nesting of sequences and mappings.
MAX_DEPTH = 32
#: Longest quotation of a value in an error message [characters].
REPR_LIMIT = 80


class YAMLInputError(ValueError):
    """A YAML document refused: malformed, too large, too deep, or with aliases."""


class DuplicateKeyError(YAMLInputError):
    """A mapping that gives one key twice: YAML leaves it to the reader, PyYAML keeps the last."""


class UniqueKeys:
    """Composer mix-in: a mapping that gives one key twice is refused, naming both lines.

    Keys are compared as written with their resolved tag (``1`` and ``'1'`` differ, as they do
    in the loaded mapping).
    """

    #: Name of the document in messages; composers that know it set it.
    _source = 'YAML'

    def compose_mapping_node(self, anchor: Optional[str]) -> MappingNode:
        node = super().compose_mapping_node(anchor)  # type: ignore[misc]  # mixed with Composer
        first: dict[tuple[str, Any], Mark] = {}
        for key, _ in node.value:
            if not isinstance(key, ScalarNode):
                continue
            seen = first.setdefault((key.tag, key.value), key.start_mark)
            if seen is not key.start_mark:
                raise DuplicateKeyError(
                    f'{self._source}: {_where(key.start_mark)}: key {short_repr(key.value)} '
                    f'given twice (first at {_where(seen)}); one value would silently win')
        return node


class _BoundedComposer(UniqueKeys, Composer):
    """The PyYAML composer, counting nodes and depth, refusing aliases (and anchors if asked)."""

    def __init__(self, source: str, anchors: bool = True) -> None:
        super().__init__()
        self._source, self._anchors, self._nodes, self._depth = source, anchors, 0, 0

    def compose_node(self, parent: Optional[Node], index: object) -> Node:
        if self.check_event(AliasEvent):
            mark = self.peek_event().start_mark
            if not self._anchors:
                raise self._anchor_error(mark)
            raise YAMLInputError(f'{self._source}: {_where(mark)}: YAML aliases (*name) are '
                                 f'not accepted; write the value out')
        if not self._anchors and getattr(self.peek_event(), 'anchor', None) is not None:
            raise self._anchor_error(self.peek_event().start_mark)
        self._nodes += 1
        if self._nodes > MAX_NODES:
            raise YAMLInputError(f'{self._source}: {_where(self.peek_event().start_mark)}: '
                                 f'more than {MAX_NODES} YAML nodes')
        self._depth += 1
        try:
            if self._depth > MAX_DEPTH:
                raise YAMLInputError(f'{self._source}: {_where(self.peek_event().start_mark)}:'
                                     f' nested deeper than {MAX_DEPTH} levels')
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def _anchor_error(self, mark: Mark) -> YAMLInputError:
        return YAMLInputError(f'{self._source}: {_where(mark)}: YAML anchors and aliases '
                              f'(&name, *name) are not accepted; write values out')


class _Loader(_BoundedComposer, _Parser, SafeConstructor, Resolver):
    """Safe construction of plain values from a bounded composition (see the module)."""

    def __init__(self, text: str, source: str, anchors: bool = True) -> None:
        _Parser.__init__(self, text)
        _BoundedComposer.__init__(self, source, anchors)
        SafeConstructor.__init__(self)
        Resolver.__init__(self)


class _DecimalLoader(_Loader):
    """:class:`_Loader` reading only decimal numbers as numbers (``decimal_numbers``)."""

    yaml_implicit_resolvers = {
        first: [(tag, pattern) for tag, pattern in resolvers
                if tag not in ('tag:yaml.org,2002:int', 'tag:yaml.org,2002:float')]
        for first, resolvers in Resolver.yaml_implicit_resolvers.items()}


_DecimalLoader.add_implicit_resolver('tag:yaml.org,2002:int', re.compile(r'^[-+]?[0-9]+$'),
                                     list('-+0123456789'))
_DecimalLoader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:[0-9]+\.[0-9]*|\.[0-9]+|[0-9]+)(?:[eE][-+]?[0-9]+)?$'
               r'|^[-+]?\.(?:inf|Inf|INF)$|^\.(?:nan|NaN|NAN)$'),
    list('-+0123456789.'))


#: YAML's line breaks (a ``\r\n`` is one).
_LINE_BREAK = re.compile('\r\n|[\n\r\x85\u2028\u2029]')


def _where(mark: Mark) -> str:
    return f'line {mark.line + 1}, column {mark.column + 1}'


def _yaml_reason(error: yaml.YAMLError, text: str) -> str:
    """One line from a PyYAML error in ``text``: where and what, without the quoted lines.

    An error at the end of a text without a final line break is placed after its last
    character, as PyYAML's Python parser places it: libyaml's names the line after the text.
    """
    mark = getattr(error, 'problem_mark', None)
    problem = getattr(error, 'problem', None)
    if mark is None or problem is None:
        return _one_line(error)
    where = _where(mark)
    if mark.index >= len(text) and text and _LINE_BREAK.fullmatch(text[-1]) is None:
        lines = _LINE_BREAK.split(text)
        where = f'line {len(lines)}, column {len(lines[-1]) + 1}'
    context = getattr(error, 'context', None)
    return _one_line(f'{where}: {problem}' + (f' ({context})' if context else ''))


def _one_line(message: object, limit: int = 300) -> str:
    return _short(' '.join(str(message).split()), limit)


def load_yaml(text: str, source: str = 'YAML', max_characters: Optional[int] = None,
              anchors: bool = True, decimal_numbers: bool = False) -> Any:
    """Return the plain value of one YAML document; refuse it (:class:`YAMLInputError`).

    ``source`` names the document in the messages (a path, a parameter). Rules a reader may
    add (the fault scripts do):

    - ``max_characters``: a smaller size bound than :data:`MAX_CHARACTERS`;
    - ``anchors=False``: an anchor (``&name``) is refused as well as an alias, naming its
      line and column; without aliases it has no use, and a reader may say so at once;
    - ``decimal_numbers=True``: only decimal numbers are numbers (``60``, ``-1``, ``2e2``,
      ``2.0e-8``, ``.inf``, ``.nan``); what YAML 1.1 would also read as a number stays text:
      times ``12:30`` (sexagesimal 750), ``0x1f``, ``0o17``, ``1_000``.
    """
    if not isinstance(text, str):
        raise YAMLInputError(f'{source}: YAML must be text, got {type(text).__name__}')
    bound = MAX_CHARACTERS if max_characters is None else min(max_characters, MAX_CHARACTERS)
    if len(text) > bound:
        raise YAMLInputError(f'{source}: longer than {bound} characters')
    loader = (_DecimalLoader if decimal_numbers else _Loader)(text, source, anchors)
    try:
        return loader.get_single_data()
    except YAMLInputError:
        raise
    except yaml.YAMLError as error:
        raise YAMLInputError(f'{source}: malformed YAML: {_yaml_reason(error, text)}') from None
    except (ValueError, OverflowError) as error:  # a scalar the constructor cannot convert
        raise YAMLInputError(f'{source}: a value cannot be read: {_one_line(error)}') from None
    finally:
        loader.dispose()


def read_yaml(path: PathLike, source: Optional[str] = None) -> Any:
    """Read a YAML file within the bounds of :func:`load_yaml` and return its value.

    Raises :class:`YAMLInputError` for the document and ``OSError`` for the file.
    """
    source = str(path) if source is None else source
    with open(path, encoding='utf-8', errors='strict') as stream:
        try:
            text = stream.read(MAX_CHARACTERS + 1)
        except UnicodeDecodeError as error:
            raise YAMLInputError(f'{source}: not UTF-8 text ({error.reason} at byte '
                                 f'{error.start})') from None
    return load_yaml(text, source)


_REPR = reprlib.Repr()
_REPR.maxstring = _REPR.maxother = REPR_LIMIT
_REPR.maxlevel, _REPR.maxdict, _REPR.maxlist, _REPR.maxtuple, _REPR.maxset = 3, 4, 6, 6, 6


def short_repr(value: object) -> str:
    """``repr(value)`` in at most about :data:`REPR_LIMIT` characters, whatever the value."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f'<an integer of {value.bit_length()} bits>'  # repr() could refuse it
    try:
        return _short(_REPR.repr(value), REPR_LIMIT)
    except Exception:  # noqa: B902 - a value whose repr fails is still named by its type
        return f'<a {type(value).__name__}>'


def _short(text: str, limit: int) -> str:
    return text if len(text) <= limit else f'{text[:limit - 3]}...'
