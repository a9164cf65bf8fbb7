"""Finding the library function a job kind calls, failing cleanly when it is not installed.

align/eval/export call functions owned by other packages (`sim2real.align_encoder`,
`core.deploy.evaluate_policy`, `core.deploy.export_onnx`, all keyword-only). When the module or
the function is missing, the job fails with a `JobKindUnavailable` reason naming what is missing;
the worker never crashes on it.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from typing import Any

from service.errors import JobKindUnavailable


def library_function(kind: str, candidates: list[tuple[str, str]]) -> Callable[..., Any]:
    """The first importable `module.function` of `candidates`, or JobKindUnavailable."""
    missing = []
    for module_name, function_name in candidates:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as error:
            if error.name and not module_name.startswith(error.name) and error.name != module_name:
                raise  # the module exists but one of its own imports is missing: a real error
            missing.append(f"{module_name}.{function_name}")
            continue
        function = getattr(module, function_name, None)
        if callable(function):
            return function
        missing.append(f"{module_name}.{function_name}")
    raise JobKindUnavailable(
        f"{kind} jobs need {' or '.join(missing)}, which this installation does not provide yet"
    )


def call_with_options(function: Callable[..., Any], *args: Any, **options: Any) -> Any:
    """Call `function` with the options it declares; None values are left to its own defaults."""
    parameters = inspect.signature(function).parameters
    takes_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values())
    chosen = {k: v for k, v in options.items() if v is not None and (takes_any or k in parameters)}
    return function(*args, **chosen)


def as_summary(result: Any) -> dict[str, Any]:
    """A library function's return value as a JSON-able summary dict."""
    if result is None:
        return {}
    if isinstance(result, dict):
        return result
    for method in ("to_dict", "model_dump", "_asdict"):
        if hasattr(result, method):
            return dict(getattr(result, method)())
    if hasattr(result, "__dataclass_fields__"):
        import dataclasses

        return dataclasses.asdict(result)
    return {"result": str(result)}
