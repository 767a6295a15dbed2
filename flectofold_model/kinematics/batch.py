"""What the panel batches of both kinds share: panels of one kind as arrays of shape ``(N,)``."""

from dataclasses import fields
from typing import Any, ClassVar, Iterable, Self, Union

import numpy as np


class PanelArrays:
    """Mixin of a frozen dataclass whose fields are its panel class's fields, as arrays (N,).

    A subclass sets :attr:`panel_class`, the validated single-panel dataclass it stacks.
    """

    panel_class: ClassVar[Any] = None
    __dataclass_fields__: ClassVar[dict[str, Any]]  # a dataclass's, for the type checker

    @classmethod
    def from_panels(cls, panels: Iterable[Any]) -> Self:
        """Stack validated panels of :attr:`panel_class` (any iterable, at least one)."""
        panels = list(panels)
        if not panels:
            raise ValueError('a panel batch needs at least one panel')
        name = cls.panel_class.__name__
        for index, panel in enumerate(panels):
            if not isinstance(panel, cls.panel_class):
                article = 'an' if name[0] in 'AEIOU' else 'a'
                raise TypeError(f'panel {index} is a {type(panel).__name__}, not {article} '
                                f'{name}')
        return cls(**{field.name: np.array([getattr(p, field.name) for p in panels])
                      for field in fields(cls)})

    @classmethod
    def repeat(cls, panel: Any, count: Union[int, np.integer[Any]]) -> Self:
        """``count`` copies of one panel."""
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
            raise ValueError(f'count must be a positive integer, got {count!r}')
        return cls.from_panels([panel]).take(np.zeros(int(count), dtype=np.intp))

    def take(self, indices: Any) -> Self:
        """Return the sub-batch at ``indices`` (any numpy index)."""
        return type(self)(**{field.name: getattr(self, field.name)[indices]
                             for field in fields(self)})

    def __len__(self) -> int:
        return getattr(self, fields(self)[0].name).shape[0]
