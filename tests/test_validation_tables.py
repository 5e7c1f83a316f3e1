"""scripts/validation.py: the statistics behind the generated tables of docs/validation.md, and the
rendering of a generated block, on synthetic replica files (no simulation)."""

import importlib.util
import json
import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture()
def v(tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location("validation_script", ROOT / "scripts" / "validation.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    monkeypatch.setattr(mod, "DATA", tmp_path)
    return mod


def _write(v, row, fcs, fts, status="ok"):
    with open(v.DATA / f"{row}.jsonl", "w") as fh:
        for k, (fc, ft) in enumerate(zip(fcs, fts)):
            fh.write(json.dumps({"k": k, "status": status, v.FC: fc, v.FT: ft}) + "\n")


def test_stats_mean_standard_error_and_resultant(v):
    _write(v, "quick-0", [10.0, 12.0, 14.0, 16.0], [3.0, 4.0, 5.0, 6.0])
    s = v.stats("quick-0")
    m, se, sd, n = s[v.FC]
    assert (m, n) == (13.0, 4)
    assert sd == pytest.approx(math.sqrt(20.0 / 3.0))
    assert se == pytest.approx(sd / 2.0)
    res = [math.hypot(a, b) for a, b in zip([10, 12, 14, 16], [3, 4, 5, 6])]
    assert s["resultant_force_N_per_mm"][0] == pytest.approx(sum(res) / 4)
    assert v.cov(s) == f"{sd / 13.0:.1%}"


def test_failed_replicas_are_counted_but_not_averaged(v):
    _write(v, "quick-0", [10.0, 12.0], [1.0, 1.0])
    with open(v.DATA / "quick-0.jsonl", "a") as fh:
        fh.write(json.dumps({"k": 2, "status": "unstable", v.FC: 1000.0, v.FT: 0.0}) + "\n")
    s = v.stats("quick-0")
    assert s[v.FC][0] == 11.0 and s["n"] == 2 and s["n_all"] == 3
    assert v.n_of(s) == "2 of 3"
    # replica k = 2 is on file (unstable), k = 3 and on to the row's wanted count are not
    assert v._missing("quick-0") == list(range(3, v.ROWS["quick-0"][3]))


def test_change_and_its_judgement(v):
    _write(v, "quick-0", [100.0, 102.0, 98.0, 100.0], [1, 1, 1, 1])
    _write(v, "quick-0-h2", [90.0, 92.0, 88.0, 90.0], [1, 1, 1, 1])
    c = v.change(v.stats("quick-0"), v.stats("quick-0-h2"), v.FC)
    assert c[0] == pytest.approx(-0.10)
    se_a = se_b = math.sqrt(8.0 / 3.0) / 2.0
    assert c[1] == pytest.approx(math.sqrt(se_b ** 2 + 0.81 * se_a ** 2) / 100.0)
    assert v.within(c, 0.20) == "yes"        # -10 % +- 2 x 1.2 % inside +-20 %
    assert v.within(c, 0.05) == "no"         # the whole interval below -5 %
    assert v.within(c, 0.10) == "not resolved"
    assert v.within(None, 0.1) == "not measured"


def test_falls_needs_two_standard_errors(v):
    _write(v, "quick-0-rake0", [20.0, 21.0, 19.0, 20.0], [1, 1, 1, 1])
    _write(v, "quick-0-rake15", [15.0, 16.0, 14.0, 15.0], [1, 1, 1, 1])
    _write(v, "quick-0", [19.5, 20.5, 18.5, 19.5], [1, 1, 1, 1])
    r0, r15, r30 = (v.stats(n) for n in ("quick-0-rake0", "quick-0-rake15", "quick-0"))
    assert v.falls(r0, r15) == "yes"
    assert v.falls(r15, r30) == "no"
    assert v.falls(r0, r30) == "not resolved"   # 0.25 N/mm apart, standard error 0.58


def test_render_replaces_only_the_generated_block(v, tmp_path, monkeypatch):
    _write(v, "quick-0", [10.0, 12.0], [3.0, 5.0])
    doc = tmp_path / "page.md"
    doc.write_text("intro\n<!-- generated: convergence -->\nold table\n<!-- end generated -->\noutro\n")
    monkeypatch.setattr(v, "DOCS", [doc])
    monkeypatch.setattr(v, "CONVERGENCE_TABLE", ["quick-0"])
    v.render()
    text = doc.read_text()
    assert text.startswith("intro\n<!-- generated: convergence -->\n| level |") and text.endswith("<!-- end generated -->\noutro\n")
    assert "old table" not in text and "| 11.00 +- 1.00 | 4.00 +- 1.00 |" in text


def test_rows_measured_with_the_creeping_friction_are_marked_in_the_tables(v, monkeypatch):
    _write(v, "quick-0", [10.0, 12.0], [1.0, 1.0])
    _write(v, "quick-0-rake0", [20.0, 22.0], [1.0, 1.0])
    assert set(v.CREEPING_FRICTION) <= set(v.ROWS)  # every marked row is a row
    monkeypatch.setattr(v, "CREEPING_FRICTION", frozenset({"quick-0-rake0"}))
    lines = v.table_quick(["quick-0", "quick-0-rake0"]).splitlines()[2:]
    assert v.CREEPING_MARK not in lines[0] and lines[0].startswith(f"| {v.ROWS['quick-0'][0]} |")
    assert lines[1].startswith(f"| {v.ROWS['quick-0-rake0'][0]}{v.CREEPING_MARK} |")


def test_a_change_between_rows_of_different_friction_laws_is_not_computed(v, monkeypatch):
    _write(v, "quick-0", [10.0, 12.0], [1.0, 1.0])
    _write(v, "quick-0-cfl025", [20.0, 22.0], [1.0, 1.0])
    monkeypatch.setattr(v, "CONVERGENCE_TABLE", ["quick-0"])
    monkeypatch.setattr(v, "CHANGES_AGAINST", [("quick-0-cfl025", "quick-0")])
    monkeypatch.setattr(v, "CREEPING_FRICTION", frozenset())
    monkeypatch.setattr(v, "FORMER_MATRIX", frozenset())
    assert "+90.9%" in v.table_changes()  # 21 against 11
    monkeypatch.setattr(v, "CREEPING_FRICTION", frozenset({"quick-0-cfl025"}))
    assert "not comparable" in v.table_changes() and "%" not in v.table_changes().splitlines()[-1]


def test_a_replica_line_carries_its_force_history_binned_by_travel():
    """scripts/replicas.py's force history: the mean of the samples in each equal bin of tool travel across
    the cut, None for an empty bin, samples past the cut left out."""
    import numpy as np

    spec = importlib.util.spec_from_file_location("replicas_script", ROOT / "scripts" / "replicas.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    travel = np.array([0.5, 1.5, 2.5, 3.5, 7.5, 12.0])
    fc = np.array([1.0, 3.0, 10.0, np.nan, 4.0, 99.0])
    h = mod.force_history({"forces": {"travel_um": travel, "Fc": fc, "Ft": 2 * fc}}, 10.0, bins=5)
    assert h["travel_um"] == [1.0, 3.0, 5.0, 7.0, 9.0]
    assert h["Fc"] == [2.0, 10.0, None, 4.0, None]  # the NaN sample is left out of [2, 4)
    assert h["Ft"] == [4.0, 20.0, None, 8.0, None]


def test_a_replica_measured_with_frames_keeps_its_run_file_and_files_the_same_line(v, monkeypatch):
    """`measure --frames`: replicas.py gets --h5 and the frame count; the line on file drops both, so a row's data
    do not depend on whether its run files were kept."""
    calls = []

    class Done:
        returncode = 0
        stdout = json.dumps({"k": 0, "status": "ok", v.FC: 1.0, "h5": "/tmp/x-0.h5", "numerics.n_frames": 20}) + "\n"
        stderr = ""

    monkeypatch.setattr(v.subprocess, "run", lambda cmd, **kw: calls.append(cmd) or Done())
    v._one("long-0-ss2000", 0, frames=("/tmp/runs", 20))
    cmd = calls[0]
    assert cmd[cmd.index("--h5") + 1] == str(Path("/tmp/runs") / "long-0-ss2000")
    assert cmd[-1] == "numerics.n_frames=20"
    on_file = json.loads((v.DATA / "long-0-ss2000.jsonl").read_text())
    assert "h5" not in on_file and "numerics.n_frames" not in on_file and on_file[v.FC] == 1.0


def test_a_frame_count_out_of_range_is_refused(v, capsys):
    with pytest.raises(SystemExit) as e:
        v.main(["measure", "long-0-ss2000", "--frames", "runs", "0"])
    assert e.value.code == 2 and "--frames: N = '0'" in capsys.readouterr().err


def test_rows_run_with_the_former_matrix_are_marked_and_compared_with_its_twin(v, monkeypatch):
    """A row that ran with the preset's former matrix (74.7 MPa) without setting it carries the mark, and a change
    of it is measured against the former-matrix twin (ROW-matrix747) of a row measured again since, never against
    that row's present measurement."""
    assert {"quick-0-cfl025", "quick-0-far", "quick-90-h300"} <= v.FORMER_MATRIX <= set(v.ROWS)
    assert not {"quick-0", "quick-0-matrix747", "quick-0-fem3d", "quick-0-reading-a"} & v.FORMER_MATRIX
    assert v.ROWS["quick-0-matrix747"][2] == {v.MATRIX_FIELD: 74.7}
    _write(v, "quick-0", [20.0, 22.0], [1.0, 1.0])
    _write(v, "quick-0-matrix747", [10.0, 12.0], [1.0, 1.0])
    _write(v, "quick-0-cfl025", [20.0, 22.0], [1.0, 1.0])
    monkeypatch.setattr(v, "CREEPING_FRICTION", frozenset())
    monkeypatch.setattr(v, "CONVERGENCE_TABLE", ["quick-0"])
    monkeypatch.setattr(v, "CHANGES_AGAINST", [("quick-0-cfl025", "quick-0")])
    line = v.table_changes().splitlines()[-1]
    assert line.startswith(f"| {v.ROWS['quick-0-cfl025'][0]}{v.MATRIX_MARK} | ")
    assert "74.7 MPa | +90.9%" in line  # against the twin's 11, not the present 21
    assert v.not_comparable("quick-0-cfl025", "quick-0") == "matrix 74.7 MPa"
    assert v.not_comparable("quick-0-matrix747", "quick-0") == ""  # the matrix's own effect: both set or default
