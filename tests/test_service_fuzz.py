"""Property-based fuzzing of the REST API (hypothesis): no input answers 5xx.

Every operation of the OpenAPI document is called with generated path parameters, query
parameters and bodies: arbitrary JSON, and study documents that are nearly valid (each key
replaced by arbitrary JSON, numbers at extremes, unknown dotted fields, huge or odd strings).
Studies that validate are created for real (SQLite), so the creation path is fuzzed too.
"""

from __future__ import annotations

from urllib.parse import quote

import pytest
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from service.app import create_app
from service.config import Settings

pytestmark = pytest.mark.timeout(180)

json_scalar = st.one_of(st.none(), st.booleans(), st.integers(min_value=-10**20, max_value=10**20),
                        st.floats(allow_nan=False, allow_infinity=False), st.text(max_size=30))
json_value = st.recursive(json_scalar, lambda kids: st.one_of(st.lists(kids, max_size=4),
                                                             st.dictionaries(st.text(max_size=12), kids, max_size=4)), max_leaves=12)
field_names = st.sampled_from(["tool.rake_angle_deg", "tool.edge_radius_um", "cut.depth_um", "cut.speed_mm_s",
                               "numerics.element_size_um", "numerics.n_frames", "workpiece.fibre_angle_deg", "fidelity",
                               "tool", "tool.", ".x", "numerics.frame_fields", "materials.fibre.E1_GPa", "a.b.c.d"])
numbers = st.one_of(st.integers(-10**6, 10**6), st.floats(-1e12, 1e12, allow_nan=False), st.sampled_from([0, -1, 1e-300, 1e300]))
param_spec = st.one_of(
    st.fixed_dictionaries({"values": st.lists(st.one_of(numbers, st.text(max_size=5), st.booleans()), min_size=0, max_size=5)}),
    st.fixed_dictionaries({"low": numbers, "high": numbers}, optional={"log": st.booleans(), "step": numbers}),
    json_value,
)
study_doc = st.fixed_dictionaries(
    {"name": st.one_of(st.just("fuzz"), st.text(max_size=40)),
     "kind": st.sampled_from(["sweep", "optimize", "convergence", "other"]),
     "scene": st.one_of(st.sampled_from(["seed-0deg-fem-quick", "seed-90deg-fem-quick", "nope"]),
                        st.dictionaries(st.sampled_from(["tool", "cut", "fidelity", "base", "zzz"]), json_value, max_size=3))},
    optional={
        "fixed": st.one_of(st.just({"fidelity": "analytic"}), st.dictionaries(field_names, json_value, max_size=3)),
        "parameters": st.dictionaries(field_names, param_spec, max_size=3),
        "design": st.sampled_from(["grid", "lhs", "sobol", "x"]),
        "n_points": st.one_of(st.integers(-5, 20), json_value),
        "sampler": st.sampled_from(["tpe", "cmaes", "gp", "nsga2", "?"]),
        "n_trials": st.one_of(st.integers(-5, 10), json_value),
        "parallelism": st.integers(-2, 5),
        "objectives": st.one_of(st.lists(st.fixed_dictionaries({"metric": st.sampled_from(["thrust_force_N_per_mm", "x"]),
                                                                "direction": st.sampled_from(["minimize", "maximize", "up"])}),
                                         max_size=3), json_value),
        "constraints": st.one_of(st.lists(st.fixed_dictionaries({"metric": st.sampled_from(["material_removal_rate_mm2_s", "y"]),
                                                                 "op": st.sampled_from([">=", "<=", "=="]), "value": numbers}),
                                          max_size=2), json_value),
        "seed": st.one_of(st.integers(-3, 2**40), json_value),
        "max_attempts": st.integers(-1, 30),
        "extra": json_value,
    })
path_ids = st.one_of(st.integers(-10**12, 10**12).map(str), st.text(max_size=40), st.just("a" * 32),
                     st.text(alphabet="0123456789abcdef", min_size=32, max_size=32))


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    d = tmp_path_factory.mktemp("fuzz")
    return TestClient(create_app(Settings(data_dir=d, db_url=f"sqlite:///{d / 'fuzz.db'}")), raise_server_exceptions=False)


def _ok(resp):
    assert resp.status_code < 500, (resp.request.method, str(resp.request.url), resp.status_code, resp.text[:500])


@settings(max_examples=250, deadline=None, suppress_health_check=list(HealthCheck))
@given(doc=st.one_of(study_doc, json_value))
def test_post_studies_never_5xx(client, doc):
    _ok(client.post("/api/studies", json=doc))


@settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
@given(raw=st.binary(max_size=200))
def test_post_raw_bodies_never_5xx(client, raw):
    _ok(client.post("/api/studies", content=raw, headers={"content-type": "application/json"}))


@settings(max_examples=250, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_every_operation_never_5xx(client, data):
    schema = client.app.openapi()
    ops = [(path, method) for path, item in schema["paths"].items() for method in item]
    path, method = data.draw(st.sampled_from(ops))
    url = path
    for seg in [s for s in path.split("/") if s.startswith("{")]:
        value = quote(data.draw(path_ids), safe="") or "x"  # what an HTTP client sends
        url = url.replace(seg, value)
    params = data.draw(st.dictionaries(st.sampled_from(["limit", "offset", "status", "max_points", "k"]),
                                       st.one_of(st.integers(-10**12, 10**12).map(str), st.text(max_size=10)), max_size=3))
    if method == "post":
        resp = client.post(url, params=params, json=data.draw(st.one_of(study_doc, json_value)))
    else:
        resp = client.request(method.upper(), url, params=params)
    _ok(resp)
