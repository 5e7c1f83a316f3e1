"""Input the API must refuse with a 4xx, never a 5xx: non-finite numbers (which JSON cannot
carry back), ids beyond the database's integer range, booleans given as numbers."""

from __future__ import annotations

import json

import pytest
from fastapi.testclient import TestClient

from service.app import create_app
from service.config import Settings

BASE = {"name": "guards", "kind": "sweep", "scene": "seed-0deg-fem-quick", "fixed": {"fidelity": "analytic"},
        "parameters": {"tool.rake_angle_deg": {"values": [0, 10]}}}


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    d = tmp_path_factory.mktemp("guards")
    return TestClient(create_app(Settings(data_dir=d, db_url=f"sqlite:///{d / 'g.db'}")), raise_server_exceptions=False)


def _post(client, doc):
    # json.dumps writes NaN / Infinity / -Infinity literally, as a hostile client would
    return client.post("/api/studies", content=json.dumps(doc), headers={"content-type": "application/json"})


@pytest.mark.parametrize("doc, field, shown", [
    ({**BASE, "seed": float("nan")}, "seed", "NaN"),
    ({**BASE, "parameters": {"tool.rake_angle_deg": {"values": [float("inf")]}}}, "parameters.tool.rake_angle_deg.values.0", "Infinity"),
    ({**BASE, "parameters": {"tool.rake_angle_deg": {"low": float("-inf"), "high": 3}}}, "parameters.tool.rake_angle_deg.low", "-Infinity"),
    ({**BASE, "constraints": [{"metric": "wall_time_s", "op": "<=", "value": float("nan")}]}, "constraints.0.value", "NaN"),
    ({**BASE, "fixed": {"fidelity": "analytic", "cut.depth_um": float("inf")}}, "fixed.cut.depth_um", "Infinity"),
    ({**BASE, "scene": {"base": "seed-0deg-fem-quick", "tool": {"friction": float("nan")}}}, "scene.tool.friction", "NaN"),
])
def test_non_finite_numbers_answer_422_naming_the_field(client, doc, field, shown):
    r = _post(client, doc)
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert any(d.get("field") == field for d in detail), detail
    # the answer is strict JSON: the rejected value comes back as a string, never as a bare NaN
    json.loads(r.text, parse_constant=lambda c: pytest.fail(f"the answer carries a bare {c}"))
    assert any(d.get("input") == shown for d in detail), detail


@pytest.mark.parametrize("path", ["/api/studies/{}", "/api/studies/{}/trials", "/api/studies/{}/trials.csv"])
@pytest.mark.parametrize("study_id", ["9223372036854775808", "9223372036854775807", str(2**31), "1e30", "-1", "0"])
def test_ids_out_of_range_answer_4xx(client, path, study_id):
    r = client.get(path.format(study_id))
    assert r.status_code in (404, 422), (r.status_code, r.text)
    r = client.get(path.format("1"))
    assert r.status_code == 404  # in range, no such study


@pytest.mark.parametrize("study_id", ["9223372036854775808", str(2**63 - 1), "1e30"])
def test_cancel_with_ids_out_of_range_answers_4xx(client, study_id):
    r = client.post(f"/api/studies/{study_id}/cancel")
    assert r.status_code in (404, 422), (r.status_code, r.text)


def test_a_500_free_connection_stays_usable(client):
    """After a refused body the same client (keep-alive) still gets answers."""
    assert _post(client, {**BASE, "seed": float("nan")}).status_code == 422
    assert client.get("/api/health").status_code == 200


@pytest.mark.parametrize("doc, field", [
    ({**BASE, "parameters": {"tool.rake_angle_deg": {"values": [True]}}}, "parameters.tool.rake_angle_deg.values"),
    ({**BASE, "parameters": {"tool.rake_angle_deg": {"low": False, "high": 10, "step": 5}}}, "parameters.tool.rake_angle_deg.low"),
    ({**BASE, "fixed": {"fidelity": "analytic", "cut.depth_um": True}}, "fixed.cut.depth_um"),
    ({**BASE, "scene": {"base": "seed-0deg-fem-quick", "fidelity": "analytic", "tool": {"friction": True}}}, "scene.tool.friction"),
    ({**BASE, "seed": True}, "seed"),
])
def test_booleans_are_not_numbers(client, doc, field):
    r = _post(client, doc)
    assert r.status_code == 422, r.text
    assert any(d.get("field") == field for d in r.json()["detail"]), r.json()


def test_a_boolean_field_still_takes_booleans(client):
    r = _post(client, {**BASE, "parameters": {"physics.element_deletion": {"values": [True, False]}}})
    assert r.status_code == 201, r.text


def test_405_lists_every_method_of_the_path(client):
    r = client.request("OPTIONS", "/api/studies")
    assert r.status_code == 405
    assert set(r.headers["allow"].replace(" ", "").split(",")) == {"GET", "POST"}


HUGE = {"workpiece.height_um": 5000, "workpiece.length_um": 10000, "numerics.element_size_um": 0.25, "cut.length_um": 100}


def test_an_oversized_scene_answers_422_with_the_estimate(client):
    r = _post(client, {**BASE, "fixed": dict(HUGE)})
    assert r.status_code == 422, r.text
    (d,) = r.json()["detail"]
    assert d["field"] == "fixed.numerics.element_size_um" and d["input"] == 0.25
    assert "elements" in d["msg"] and "workpiece.length_um = 10000" in d["msg"] and "workpiece.height_um = 5000" in d["msg"]


def test_an_oversized_design_point_or_range_end_answers_422(client):
    big = {k: v for k, v in HUGE.items() if k != "numerics.element_size_um"}
    r = _post(client, {**BASE, "fixed": big, "parameters": {"numerics.element_size_um": {"values": [20, 0.25]}}})
    assert r.status_code == 422 and "design point 1" in r.text, r.text
    r = _post(client, {**BASE, "kind": "optimize", "n_trials": 3, "objectives": [{"metric": "thrust_force_N_per_mm"}],
                       "fixed": big, "parameters": {"numerics.element_size_um": {"low": 0.25, "high": 20}}})
    assert r.status_code == 422 and "parameters.numerics.element_size_um" in r.text, r.text


def test_the_size_limits_are_configurable(client, monkeypatch):
    monkeypatch.setenv("FIBRECUT_MAX_ELEMENTS", "100")
    from service.config import Limits

    client.app.state.settings.limits = Limits()
    try:
        r = _post(client, {**BASE, "fixed": {}})  # the quick FEM scene: a few thousand elements
        assert r.status_code == 422 and "limit 100" in r.text, r.text
    finally:
        monkeypatch.delenv("FIBRECUT_MAX_ELEMENTS")
        client.app.state.settings.limits = Limits()
    assert _post(client, {**BASE, "fixed": {}}).status_code == 201


def test_a_wall_time_above_the_servers_cap_answers_422(client):
    r = _post(client, {**BASE, "fixed": {"fidelity": "analytic", "numerics.max_wall_time_s": 600000}})
    assert r.status_code == 422 and "fixed.numerics.max_wall_time_s" in r.text, r.text
