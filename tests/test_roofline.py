"""The memory roofline of the benchmarks (solver.roofline): the triad's bandwidth and the row arithmetic."""

from types import SimpleNamespace

import numpy as np
import pytest

from solver.roofline import annotate, state_bytes, stream_bandwidth


def test_triad_bandwidth_is_measured():
    bw = stream_bandwidth(1, n=1 << 20, repeats=3)
    assert 1e8 < bw < 1e12, "a plausible memory or cache bandwidth [bytes/s]"
    assert stream_bandwidth(1, n=1 << 20) == bw, "measured once per process"


def test_row_arithmetic():
    state = SimpleNamespace(a=np.zeros((10, 4)), b=np.zeros(10, np.int32), note="not an array")
    assert state_bytes(state, 10) == pytest.approx((320 + 40) / 10)
    row = annotate({"rate": 1e6}, "rate", 800.0, 1)
    assert row["roofline_updates_per_s"] == pytest.approx(row["bandwidth_GB_s"] * 1e9 / 800.0, rel=1e-2)
    assert row["roofline_fraction"] == pytest.approx(1e6 / row["roofline_updates_per_s"])
