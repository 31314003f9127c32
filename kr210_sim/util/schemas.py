"""The JSON Schemas (draft 2020-12) of the files kr210_sim reads and writes, shipped in the
package (``kr210_sim/schemas/*.json``): ``run`` (the report ``run`` and ``view`` write),
``episode`` (a record line of ``evaluate``'s episodes file) and ``cell`` (a cell file, as TOML
loads it). Validate with any JSON Schema library, e.g.
``jsonschema.validate(report, load_schema("run"))`` (see ``docs/reference/schemas.md``)."""

from __future__ import annotations

import json
from importlib import resources
from typing import Any

from kr210_sim.errors import ConfigError

#: The schemas shipped, by name.
SCHEMAS = ("run", "episode", "cell")


def schema_text(name: str) -> str:
    """The text of schema ``name`` (``kr210_sim/schemas/<name>.schema.json``).

    Raises:
        ConfigError: When there is no such schema (the message lists those there are).
    """
    if name not in SCHEMAS:
        raise ConfigError(f"no schema {name!r} (there are: {', '.join(SCHEMAS)})")
    return resources.files("kr210_sim").joinpath("schemas", f"{name}.schema.json").read_text()


def load_schema(name: str) -> dict[str, Any]:
    """Schema ``name`` as a dictionary (see :func:`schema_text`)."""
    schema: dict[str, Any] = json.loads(schema_text(name))
    return schema
