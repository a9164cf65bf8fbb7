"""The one error body every failure returns: a message naming the field or the reason."""

from __future__ import annotations

from pydantic import BaseModel, Field


class FieldError(BaseModel):
    field: str = Field(description="Dotted path of the offending field, e.g. spec.episodes.")
    message: str


class ErrorPublic(BaseModel):
    detail: str = Field(description="One line naming the field or the reason.")
    errors: list[FieldError] = Field(default_factory=list)
