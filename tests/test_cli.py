

def test_json_output_writes_a_value_not_measured_as_null(capsys):
    """Strict JSON (no NaN token): a NaN metric, e.g. bounce-back on a cut too short to leave a machined surface,
    is written as null, also inside lists and numpy arrays."""
    import json

    import numpy as np

    from cli.main import _print_json

    _print_json({"bounce_back_um": float("nan"), "series": [1.0, float("inf")], "a": np.array([np.nan, 2.0]),
                 "f32": np.float32("nan")})
    out = json.loads(capsys.readouterr().out)
    assert out == {"bounce_back_um": None, "series": [1.0, None], "a": [None, 2.0], "f32": None}
