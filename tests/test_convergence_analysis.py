"""Richardson extrapolation and the work-precision analysis, against sequences with known limits."""

import math

import pytest

from solver.convergence import Level, analyse, richardson


@pytest.mark.parametrize("order", [1.0, 2.0, 3.5])
def test_richardson_recovers_order_and_limit(order):
    f = lambda h: 7.0 + 3.0 * h**order  # noqa: E731 - exact limit 7 at h -> 0
    p, ext = richardson(f(4.0), f(2.0), f(1.0), 2.0)
    assert p == pytest.approx(order, rel=1e-9)
    assert ext == pytest.approx(7.0, rel=1e-9)


def test_richardson_refuses_oscillating_or_diverging_sequences():
    assert richardson(1.0, 2.0, 1.5, 2.0) == (None, None)  # oscillating
    assert richardson(1.0, 2.0, 4.0, 2.0) == (None, None)  # diverging


def test_analyse_errors_order_and_cheapest_level():
    levels = []
    for h, wall in ((8.0, 1.0), (4.0, 4.0), (2.0, 16.0), (1.0, 64.0)):
        levels.append(Level(h, {"status": "ok", "wall_time_s": wall, "steps": int(wall * 100),
                                "thrust_force_N_per_mm": 10.0 + 0.2 * h**2, "cutting_force_N_per_mm": 30.0 - h,
                                "damage_depth_um": 5.0, "bounce_back_um": None}))
    conv = analyse("element_size", "numerics.element_size_um", levels, tolerance=0.05)
    assert conv.observed_order["thrust_force_N_per_mm"] == pytest.approx(2.0)
    assert conv.extrapolated["thrust_force_N_per_mm"] == pytest.approx(10.0)
    assert conv.observed_order["cutting_force_N_per_mm"] == pytest.approx(1.0)
    errs = [r["thrust_force_N_per_mm_error_vs_richardson"] for r in conv.rows]
    assert errs == sorted(errs, reverse=True)  # error falls as the cost rises
    expected = [abs(0.2 * h**2) / 10.0 for h in (8.0, 4.0, 2.0, 1.0)]
    assert errs == pytest.approx(expected)
    cheapest = [h for h, e in zip((8.0, 4.0, 2.0, 1.0), expected) if e <= 0.05][0]
    assert conv.cheapest["value"] == cheapest and conv.cheapest["against"] == "richardson"
    assert all(r["bounce_back_um_error_vs_finest"] is None for r in conv.rows)


def test_analyse_skips_failed_levels_for_the_reference():
    levels = [Level(4.0, {"status": "ok", "wall_time_s": 1.0, "thrust_force_N_per_mm": 12.0}),
              Level(2.0, {"status": "ok", "wall_time_s": 2.0, "thrust_force_N_per_mm": 11.0}),
              Level(1.0, {"status": "unstable", "wall_time_s": 0.5, "thrust_force_N_per_mm": math.nan})]
    conv = analyse("element_size", "numerics.element_size_um", levels, tolerance=0.1)
    assert conv.rows[0]["thrust_force_N_per_mm_error_vs_finest"] == pytest.approx(1.0 / 11.0)
    assert conv.rows[1]["thrust_force_N_per_mm_error_vs_finest"] is None  # the finest ok run itself
    assert conv.cheapest["value"] == 4.0


def test_work_precision_plot_is_a_png_and_rows_carry_the_indicators(tmp_path):
    from solver.convergence import plot_work_precision

    levels = [Level(h, {"status": "ok", "wall_time_s": 64.0 / h**2, "thrust_force_N_per_mm": 10.0 + h, "energy_error": 0.001 * h,
                        "dt_s": 1e-11 * h, "dt_limited_by": "element 1 (fibre)"}) for h in (8.0, 4.0, 2.0, 1.0)]
    conv = analyse("element_size", "numerics.element_size_um", levels)
    assert [r["energy_error"] for r in conv.rows] == [0.008, 0.004, 0.002, 0.001]
    assert all(r["dt_limited_by"] == "element 1 (fibre)" for r in conv.rows)
    path = plot_work_precision([conv], str(tmp_path / "wp.png"))
    with open(path, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"


def test_replicas_give_the_mean_its_standard_error_and_the_uncertainty_of_the_error():
    from solver.convergence import combine_replicas

    def rep(fc, status="ok", e=1e-4):
        return {"status": status, "wall_time_s": 2.0, "steps": 10, "cutting_force_N_per_mm": fc,
                "thrust_force_N_per_mm": 0.1 * fc, "energy_error": e}

    coarse = combine_replicas([rep(1.0), rep(2.0), rep(3.0, e=5e-4), rep(float("nan"), "unstable")])
    assert coarse["status"] == "unstable" and coarse["replicas"] == 4 and coarse["replicas_ok"] == 3
    assert coarse["cutting_force_N_per_mm"] == pytest.approx(2.0)  # the mean of the ok replicas
    assert coarse["cutting_force_N_per_mm_sd"] == pytest.approx(1.0)  # sample standard deviation
    assert coarse["cutting_force_N_per_mm_sem"] == pytest.approx(1.0 / math.sqrt(3))
    assert coarse["energy_error"] == 5e-4  # the worst replica's indicator
    assert coarse["wall_time_s"] == 8.0 and coarse["wall_time_per_run_s"] == 2.0
    fine = combine_replicas([rep(2.0), rep(2.2), rep(2.4)])
    conv = analyse("element_size", "numerics.element_size_um", [Level(5.0, {**coarse, "status": "ok"}), Level(2.5, fine)],
                   target="cutting_force_N_per_mm")
    row = conv.rows[0]
    assert row["cutting_force_N_per_mm_error_vs_finest"] == pytest.approx(0.2 / 2.2)
    sem_f = 0.2 / math.sqrt(3)
    assert row["cutting_force_N_per_mm_error_uncertainty"] == pytest.approx(math.sqrt(1 / 3 + sem_f**2) / 2.2)
    assert row["replicas"] == 4 and conv.rows[1]["replicas"] == 3
    assert row["cutting_force_N_per_mm_samples"] == [1.0, 2.0, 3.0]  # the ok replicas' values, for re-analysis


@pytest.mark.parametrize("value", ["0", "101"])
def test_cli_refuses_a_replica_count_out_of_range_with_exit_2(value, capsys):
    from cli.main import main

    assert main(["convergence", "seed-0deg-fem-quick", "--replicas", value]) == 2
    err = capsys.readouterr().err
    assert "--replicas" in err and value in err and "1 to 100" in err


@pytest.mark.parametrize("argv, field, allowed", [
    (["--replicas", "0"], "--replicas", "1 to 100"),
    (["--scenes", "seed-45deg-fem"], "--scenes", "seed-0deg-fem"),
])
def test_compare_refuses_bad_replicas_or_scenes_with_exit_2(argv, field, allowed, capsys):
    from cli.main import main

    assert main(["compare", *argv]) == 2
    err = capsys.readouterr().err
    assert field in err and argv[1] in err and allowed in err


def test_compare_with_replicas_reports_each_force_as_mean_and_standard_error(monkeypatch, capsys):
    """`fibrecut compare --replicas N` runs each scene N times with the tool speed perturbed (each run
    one sample of the chaotic cut) and reports the mean and standard error of the forces. The runs
    are replaced by a stand-in that returns forces from the speed scaling it was given, so the test
    checks the perturbation and the statistics, not the solver."""
    import json

    import solver
    from cli.main import main

    seen = []

    class Fake:
        def __init__(self, scene):
            self.scene = scene

        def summary(self):
            base = solver.load_scene(self.scene.name).numerics.speed_scaling
            k = round((self.scene.numerics.speed_scaling / base - 1.0) / 1e-6)
            seen.append(k)
            return {"status": "ok", "wall_time_s": 1.0, "cutting_force_N_per_mm": 3.0 + k,
                    "thrust_force_N_per_mm": 0.5 * k, "sph_cutting_force_N_per_mm": 0.1 * k,
                    "sph_thrust_force_N_per_mm": 0.0}

    monkeypatch.setattr(solver, "run", lambda scene, progress=None: Fake(scene))
    assert main(["compare", "--scenes", "seed-0deg-hybrid-d01", "--replicas", "3", "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert seen == [0, 1, 2]  # the scene's speed scaling x (1 + k 1e-6), k = 0, 1, 2
    assert row["scene"] == "seed-0deg-hybrid-d01-quick" and row["replicas"] == 3 and row["status"] == "ok"
    assert row["Fc_ours"] == pytest.approx(4.0) and row["Fc_ours_sem"] == pytest.approx(1.0 / math.sqrt(3))
    assert row["Ft_ours"] == pytest.approx(0.5) and row["Ft_ours_sem"] == pytest.approx(0.5 / math.sqrt(3))
    assert row["Fc_particles"] == pytest.approx(0.1) and row["wall_time_s"] == pytest.approx(3.0)
    assert row["Fc_paper"] == 35.05 and row["Ft_paper"] == 16.1


def test_compare_with_3d_sets_the_3d_strip_beside_the_2d_scenes_and_the_paper(monkeypatch, capsys):
    """`fibrecut compare --with-3d` runs the 3D strip's five seed scenes after the 2D ones, each beside the
    paper's column of its kind (classic FEM, hybrid D 0.8 or 0.1). A stand-in replaces the runs."""
    import json

    import solver
    from cli.main import main

    class Fake:
        def __init__(self, scene):
            self.scene = scene

        def summary(self):
            return {"status": "ok", "wall_time_s": 1.0, "cutting_force_N_per_mm": 1.0, "thrust_force_N_per_mm": 2.0}

    ran = []
    monkeypatch.setattr(solver, "run", lambda scene, progress=None: (ran.append(scene.fidelity), Fake(scene))[1])
    assert main(["compare", "--with-3d", "--json"]) == 0
    rows = {r["scene"]: r for r in json.loads(capsys.readouterr().out)}
    assert ran == ["fem2d", "hybrid2d", "hybrid2d", "fem2d", "hybrid2d", "fem3d", "hybrid3d", "hybrid3d", "fem3d", "hybrid3d"]
    for d in ("", "3d"):
        assert rows[f"seed-0deg-hybrid{d}-d08-quick"]["Fc_paper"] == 32.17
        assert rows[f"seed-0deg-hybrid{d}-d01-quick"]["Ft_paper"] == 16.1
        assert rows[f"seed-90deg-hybrid{d}-d01-quick"]["Ft_experiment"] == rows["seed-90deg-fem-quick"]["Ft_experiment"]
    assert rows["seed-0deg-fem3d-quick"]["Ft_paper"] == rows["seed-0deg-fem-quick"]["Ft_paper"]
    assert main(["compare", "--json"]) == 0 and len(json.loads(capsys.readouterr().out)) == 5  # 2D only by default
