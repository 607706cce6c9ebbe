"""The one timing helper the benchmarks share (run as `python benchmarks/bench_*.py`, so this directory
is on sys.path)."""

import time

import numpy as np


def timed(function, repeats: int, warmup: int = 3) -> tuple:
    """Wall-clock and process-CPU milliseconds per call (arrays). On a shared machine the wall clock
    includes waiting for a core; the CPU time does not (it may exceed the wall time with 2 threads)."""
    for _ in range(warmup):
        function()
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        function()
        wall.append((time.perf_counter() - start) * 1000.0)
        cpu.append((time.process_time() - start_cpu) * 1000.0)
    return np.array(wall), np.array(cpu)


def p50_p95(milliseconds) -> tuple:
    return tuple(float(v) for v in np.percentile(milliseconds, [50, 95]))
