"""Timing helper shared by the benchmarks."""

import time

import numpy as np


def best_and_median(function, repeats):
    """Best and median wall time [s] of ``repeats`` calls of ``function``."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times), float(np.median(times))
