"""OpenAPI links: how one operation's answer names the input of the next (create → read → update →
delete), so a generated client, and schemathesis' stateful phase, can chain them.

Operation ids are the route functions' names (`create_api` sets `generate_unique_id_function`).
"""

from __future__ import annotations

from typing import Any


def link(operation_id: str, description: str, **parameters: str) -> dict[str, Any]:
    """One OpenAPI Link object: `parameters` map a parameter name to a runtime expression."""
    return {"operationId": operation_id, "description": description, "parameters": parameters}


def linked(status_code: int, description: str, **links: dict[str, Any]) -> dict[int, dict[str, Any]]:
    """A `responses=` entry for FastAPI: the status's description and its links."""
    return {status_code: {"description": description, "links": links}}
