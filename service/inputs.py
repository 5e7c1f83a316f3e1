"""Guards on what users send, shared by the API and the CLI.

- :func:`jsonable`: a value as JSON can carry it (non-finite numbers become the strings
  ``"NaN"``, ``"Infinity"``, ``"-Infinity"``), for echoing rejected input in a 422.
- :func:`nonfinite_paths`: where a parsed JSON document holds NaN or Infinity.
- :func:`bool_problems`: booleans given for numeric scene fields (pydantic's lax mode would
  read ``true`` as 1).
- :func:`load_yaml`: YAML with a size limit and without aliases (an alias bomb expands a
  few hundred bytes into gigabytes).
"""

from __future__ import annotations

import math
import types
import typing
from typing import Any

MAX_YAML_BYTES = 1_000_000


def jsonable(v: Any, depth: int = 0) -> Any:
    if isinstance(v, float) and not math.isfinite(v):
        return "NaN" if math.isnan(v) else ("Infinity" if v > 0 else "-Infinity")
    if isinstance(v, (str, int, float, bool)) or v is None:
        return v
    if depth > 20:
        return "..."
    if isinstance(v, dict):
        return {str(k): jsonable(x, depth + 1) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [jsonable(x, depth + 1) for x in v]
    return str(v)


def nonfinite_paths(v: Any, path: tuple = (), depth: int = 0) -> list[tuple]:
    """Paths (keys and indices) of every NaN or Infinity inside a parsed JSON value."""
    if isinstance(v, float):
        return [] if math.isfinite(v) else [path]
    if depth > 50:
        return []
    if isinstance(v, dict):
        return [p for k, x in v.items() for p in nonfinite_paths(x, path + (str(k),), depth + 1)]
    if isinstance(v, list):
        return [p for i, x in enumerate(v) for p in nonfinite_paths(x, path + (i,), depth + 1)]
    return []


def _is_numeric(annotation) -> bool:
    if annotation in (int, float):
        return True
    if isinstance(annotation, types.UnionType) or typing.get_origin(annotation) is typing.Union:
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        return bool(args) and all(a in (int, float) for a in args)
    return False


def numeric_field(dotted: str) -> bool:
    from solver.scene import _field_info

    info = _field_info(dotted.split("."))
    return info is not None and _is_numeric(info.annotation)


def bool_problems(values: dict[str, Any]) -> list[tuple[str, Any, str]]:
    """(field, value, message) for every boolean given to a numeric field; ``values`` maps dotted
    names to values (overrides), or is a nested scene dict (walked to its leaves)."""
    from solver.scene import allowed_range

    out = []

    def visit(prefix: str, v: Any) -> None:
        if isinstance(v, dict) and not (prefix and numeric_field(prefix)):
            for k, x in v.items():
                visit(f"{prefix}.{k}" if prefix else str(k), x)
            return
        if isinstance(v, bool) and numeric_field(prefix):
            rng = allowed_range(prefix)
            out.append((prefix, v, "a boolean is not a number" + (f"; {rng}" if rng else "; give a number")))

    for k, x in values.items():
        visit(str(k), x)
    return out


class YamlError(ValueError):
    pass


def load_yaml(text: str | bytes, what: str, max_bytes: int = MAX_YAML_BYTES) -> Any:
    """Parse YAML/JSON of at most ``max_bytes``, refusing anchors and aliases; raises YamlError
    with one line naming ``what``."""
    import yaml

    size = len(text.encode() if isinstance(text, str) else text)
    if size > max_bytes:
        raise YamlError(f"{what}: {size} bytes; allowed at most {max_bytes} bytes")

    class _NoAliases(yaml.SafeLoader):
        def compose_node(self, parent, index):
            if self.check_event(yaml.AliasEvent):
                event = self.peek_event()
                raise YamlError(f"{what}: YAML aliases (*{event.anchor}) are not allowed; write the values out "
                                f"(line {event.start_mark.line + 1})")
            event = self.peek_event()
            if getattr(event, "anchor", None):
                raise YamlError(f"{what}: YAML anchors (&{event.anchor}) are not allowed; write the values out "
                                f"(line {event.start_mark.line + 1})")
            return super().compose_node(parent, index)

    try:
        return yaml.load(text, Loader=_NoAliases)  # noqa: S506 - a SafeLoader subclass
    except YamlError:
        raise
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise YamlError(f"{what}: not valid YAML/JSON: {str(exc).splitlines()[0]}") from None
