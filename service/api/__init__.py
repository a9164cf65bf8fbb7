"""The FastAPI layer: one router per resource, shared dependencies, errors, limits."""
