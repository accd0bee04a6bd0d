"""Repeated calls do not grow memory (resident set size measured from /proc)."""

from __future__ import annotations

import gc
import sys

import numpy as np
import pytest

import unicac

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/statm")


def _rss_mb() -> float:
    with open("/proc/self/statm") as f:
        pages = int(f.read().split()[1])
    import os

    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def _growth_mb(call, warmup: int, repeats: int) -> tuple[float, float]:
    for _ in range(warmup):
        call()
    gc.collect()
    before = _rss_mb()
    for _ in range(repeats):
        call()
    gc.collect()
    after = _rss_mb()
    return before, after - before


def test_trace_and_simulate_do_not_leak(cooke):
    rng = np.random.default_rng(0)
    n = 100_000  # 100k rays: 2.4 MB in, 2 MB out per call
    starts = np.column_stack([rng.uniform(-5, 5, n), rng.uniform(-5, 5, n), np.full(n, -5.0)])
    dirs = np.column_stack([np.zeros(n), np.zeros(n), np.ones(n)])
    before, grown = _growth_mb(lambda: unicac.trace(cooke, starts, dirs), warmup=5, repeats=100)
    print(f"trace x100 (100k rays): RSS {before:.1f} MB, growth {grown:+.1f} MB (~400 MB passed through)")
    assert grown < 20.0

    sim = unicac.Simulator(cooke, 256, 192)
    image = unicac.chart("dead-leaves", 256, 192, seed=0)
    before, grown = _growth_mb(lambda: sim.render_pair(image, seed=1), warmup=3, repeats=60)
    print(f"render_pair x60 (256x192): RSS {before:.1f} MB, growth {grown:+.1f} MB (~70 MB passed through)")
    assert grown < 20.0

    before, grown = _growth_mb(lambda: unicac.psf(cooke, 10.0, wavelengths_um=[0.55]), warmup=3, repeats=50)
    print(f"psf x50: RSS {before:.1f} MB, growth {grown:+.1f} MB")
    assert grown < 20.0

    def failing():
        with pytest.raises(TypeError):
            unicac.trace(cooke, starts.astype(np.float32), dirs)

    before, grown = _growth_mb(failing, warmup=3, repeats=200)
    print(f"rejected calls x200: growth {grown:+.1f} MB")
    assert grown < 10.0
