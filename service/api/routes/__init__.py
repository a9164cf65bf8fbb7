"""One router per resource: jobs, policies, health."""
