"""The SPH benchmark's bookkeeping (not its speed: speed is measured by `fibrecut bench sph`)."""


def test_bench_rows_report_the_best_and_the_median_of_their_repeats():
    from solver.bench_sph import bench

    (row,) = bench(threads=[1], sizes=[400], target_s=0.3, repeats=3)
    assert row["status"] == "ok" and row["repeats"] == 3 and row["size"] == 400
    assert row["updates_per_s"] >= row["updates_per_s_median"] > 0 and row["spread"] >= 0
    assert row["ns_per_update"] * row["updates_per_s"] == 1e9 or abs(row["ns_per_update"] * row["updates_per_s"] / 1e9 - 1) < 1e-12
    (bad,) = bench(threads=[10**6], sizes=[400])
    assert "error" in bad  # more threads than numba has: a row that says so, no crash
