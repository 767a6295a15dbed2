"""Scan lines across the footprints, and the exact union of intervals along them."""

import math

import numpy as np
import pytest

from flectofold_model.shading import scan_lines
from flectofold_model.shading.hexagon_tiling import SIDE_NORMALS


def footprint_points(lines, t):
    """(M, 2) points ``(xi, eta)`` of every line at its parameters ``t`` (M,)."""
    return lines.origin[:, :2] + t[:, None] * lines.direction[:2]


@pytest.mark.parametrize('samples', [1, 5, 16, 24])
def test_quad_lines_cover_the_footprint_in_equal_strips(samples):
    lines = scan_lines.quad_lines(samples)
    assert lines.start.size == scan_lines.LINES_PER_SAMPLE * samples
    # The chords end on the outline of the unit square (units of L and W).
    for t in (lines.start, lines.end):
        size = np.abs(footprint_points(lines, t)).max(axis=1)
        np.testing.assert_allclose(size, 0.5, atol=1e-6)
    # Midlines of equal strips: chords times the strips' width add up to the square's area
    # (the midpoint rule is exact but for the strips at the four corners).
    assert np.sum(lines.end - lines.start) * lines.spacing == pytest.approx(1.0, rel=2e-2)
    np.testing.assert_allclose(np.diff(lines.offset), lines.spacing, rtol=1e-9)
    np.testing.assert_allclose(lines.origin[:, :2] @ lines.across, lines.offset, atol=1e-12)
    # Neither along x nor along y: straight shadow edges along them cross every line.
    assert abs(lines.direction[0]) > 0.3 and abs(lines.direction[1]) > 0.3


def test_hexagon_lines_cover_the_hexagon_in_equal_strips():
    lines = scan_lines.hexagon_lines(24, SIDE_NORMALS)
    scale = np.array([math.sqrt(3.0), 2.0])  # bounding-box units to units of R
    for t in (lines.start, lines.end):
        points = footprint_points(lines, t) * scale
        across = np.abs(points @ SIDE_NORMALS.T).max(axis=1)
        np.testing.assert_allclose(across, math.sqrt(3.0) / 2, atol=1e-6)
    area = np.sum(lines.end - lines.start) * lines.spacing
    assert area == pytest.approx(1.5 * math.sqrt(3.0), rel=1e-3)
    # t is in units of R along the lines: a unit step of t is a length R.
    assert np.linalg.norm(lines.direction[:2] * scale) == pytest.approx(1.0)
    angle = math.degrees(math.atan2(*(lines.direction[1::-1] * scale[::-1])))
    assert min(angle % 30.0, 30.0 - angle % 30.0) == pytest.approx(15.0)


def union_by_hand(start, end):
    total, reach = 0.0, -math.inf
    for s, e in sorted(zip(start, end)):
        if e > reach:
            total += e - max(s, reach)
            reach = e
    return total


def test_covered_length_is_the_union_of_each_panels_intervals():
    rng = np.random.default_rng(2)
    lines = scan_lines.quad_lines(2)
    count, size = 3, 400
    owner = rng.integers(0, count, size)
    line = rng.integers(0, lines.start.size, size)
    width = lines.end[line] - lines.start[line]
    a = lines.start[line] + rng.uniform(0.0, 1.0, size) * width
    b = lines.start[line] + rng.uniform(0.0, 1.0, size) * width
    start, end = np.minimum(a, b), np.maximum(a, b)
    covered = scan_lines.covered_length(owner, line, start, end, count + 1, lines.start.size)
    for panel in range(count):
        expected = sum(union_by_hand(start[(owner == panel) & (line == m)],
                                     end[(owner == panel) & (line == m)])
                       for m in range(lines.start.size))
        assert covered[panel] == pytest.approx(expected, abs=1e-8)
    assert covered[count] == 0.0
    # Exact on its integer grid: the same to the last bit in any order.
    order = rng.permutation(size)
    again = scan_lines.covered_length(owner[order], line[order], start[order], end[order],
                                      count + 1, lines.start.size)
    np.testing.assert_array_equal(again, covered)


def test_a_fully_covered_footprint_gives_exactly_its_chords():
    lines = scan_lines.hexagon_lines(16, SIDE_NORMALS)
    middle = (lines.start + lines.end) / 2
    line = np.tile(np.arange(lines.start.size), 2)
    start = np.concatenate([lines.start, middle - 1e-3])
    end = np.concatenate([middle, lines.end])
    covered = scan_lines.covered_length(np.zeros(line.size, dtype=int), line, start, end, 1,
                                        lines.start.size)
    assert covered[0] / scan_lines.chord_length(lines) == 1.0
