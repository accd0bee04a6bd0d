"""Tracing and rendering release the GIL: Python threads keep running during a long native call."""

from __future__ import annotations

import threading
import time

import numpy as np

import unicac


def _ticks_during(call) -> tuple[int, float]:
    ticks = 0
    stop = threading.Event()

    def counter():
        nonlocal ticks
        while not stop.is_set():
            ticks += 1
            time.sleep(0.001)

    thread = threading.Thread(target=counter)
    thread.start()
    start = time.perf_counter()
    call()
    elapsed = time.perf_counter() - start
    stop.set()
    thread.join()
    return ticks, elapsed


def test_trace_releases_the_gil(cooke):
    n = 2_000_000
    starts = np.zeros((n, 3))
    starts[:, 1] = np.linspace(-5, 5, n)
    starts[:, 2] = -5.0
    dirs = np.zeros((n, 3))
    dirs[:, 2] = 1.0
    ticks, elapsed = _ticks_during(lambda: unicac.trace(cooke, starts, dirs))
    # With the GIL held the counter thread could not run during the call at all (beyond the switch
    # interval before it); released, it ticks about once per millisecond.
    print(f"trace of {n} rays: {elapsed:.2f} s, {ticks} ticks of a Python thread meanwhile")
    assert elapsed < 0.05 or ticks >= max(3, 0.2 * elapsed * 1000)


def test_simulate_releases_the_gil(cooke):
    sim = unicac.Simulator(cooke, 512, 384)
    image = unicac.chart("dead-leaves", 512, 384, seed=0)
    ticks, elapsed = _ticks_during(lambda: sim.simulate(image, seed=0))
    print(f"simulate 512x384: {elapsed:.2f} s, {ticks} ticks of a Python thread meanwhile")
    assert elapsed < 0.05 or ticks >= max(3, 0.2 * elapsed * 1000)
