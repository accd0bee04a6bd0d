"""Forked processes (PyTorch DataLoader workers on Linux) can call unicac after the parent has used
it: the native module gives each process its own thread pool."""

from __future__ import annotations

import multiprocessing
import sys

import numpy as np
import pytest

import unicac

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="fork start method")


def _child(queue) -> None:
    lens = unicac.load_lens("builtin:cooke_triplet")
    n = 10_000
    starts = np.zeros((n, 3))
    starts[:, 2] = -5.0
    dirs = np.zeros((n, 3))
    dirs[:, 2] = 1.0
    _, status = unicac.trace(lens, starts, dirs)
    sim = unicac.Simulator(lens, 64, 48)
    out = sim.simulate(unicac.chart("dead-leaves", 64, 48, seed=1), seed=1)
    queue.put((int((status == 0).sum()), out.shape))


def test_calls_work_in_a_forked_child(cooke):
    # Use the thread pool in the parent first, as a training script does before its loader forks.
    unicac.trace(cooke, np.zeros((5000, 3)) + [0.0, 0.0, -5.0], np.zeros((5000, 3)) + [0.0, 0.0, 1.0])
    unicac.Simulator(cooke, 64, 48)
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    child = context.Process(target=_child, args=(queue,))
    child.start()
    child.join(timeout=120)
    if child.is_alive():
        child.kill()
        pytest.fail("the forked child hung in a native call")
    assert child.exitcode == 0
    ok, shape = queue.get(timeout=5)
    assert ok == 10_000 and shape == (48, 64, 3)
