"""Facades shared by the benchmarks."""

from pathlib import Path

from flectofold_model.facade.description import DEFAULT_FACADE


def large_facade_text(rows=25, columns=40):
    """YAML of the demonstrator's modules on a ``rows`` x ``columns`` grid, 1.1 m pitch.

    The default facade's description with its grid, size and (flattened) curvature replaced:
    1,000 panels at the defaults.
    """
    text = Path(DEFAULT_FACADE).read_text()
    for old, new in (('rows: 6', f'rows: {rows}'), ('columns: 6', f'columns: {columns}'),
                     ('width_m: 6.6', f'width_m: {1.1 * columns:.1f}'),
                     ('height_m: 6.6', f'height_m: {1.1 * rows:.1f}'),
                     ('curvature_u_per_m: 0.08', 'curvature_u_per_m: 0.004'),
                     ('curvature_v_per_m: -0.08', 'curvature_v_per_m: -0.004')):
        assert old in text, old
        text = text.replace(old, new)
    return text
