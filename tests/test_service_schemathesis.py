"""schemathesis against the app's own OpenAPI document: every operation, generated inputs
(valid and invalid), a bounded number of examples. Checks: no 5xx, every status code and
content type documented, answers that match their schema, 405s with a correct ``Allow``."""

from __future__ import annotations

import atexit
import shutil
import tempfile
from pathlib import Path

import pytest
import schemathesis
from hypothesis import HealthCheck, settings
from schemathesis.checks import (content_type_conformance, not_a_server_error, response_schema_conformance,
                                 status_code_conformance, unsupported_method)

from service.app import create_app
from service.config import Settings

pytestmark = pytest.mark.timeout(300)


_dir = Path(tempfile.mkdtemp(prefix="fibrecut-schemathesis-"))
atexit.register(shutil.rmtree, _dir, True)
schema = schemathesis.openapi.from_asgi("/openapi.json", create_app(Settings(data_dir=_dir, db_url=f"sqlite:///{_dir / 'st.db'}")))


@schema.parametrize()
@settings(max_examples=25, deadline=5000, suppress_health_check=list(HealthCheck), derandomize=True)
def test_every_operation_answers_as_documented(case):
    case.call_and_validate(checks=[not_a_server_error, status_code_conformance, content_type_conformance,
                                   response_schema_conformance, unsupported_method])
