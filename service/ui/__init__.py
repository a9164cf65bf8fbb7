"""The job service's web dashboard: server-rendered pages under `/ui` (see docs/service.md, Dashboard),
served by the API process(es) beside the REST routes (`service.server.create_app` installs them; the
dashboard never imports `service.api`, nor the API it: both use `service.deps`).

`routes.py` (the pages and `install_dashboard`), `views.py` (what a page shows of a job),
`rendering.py` (Jinja2 environment, static files), `templates/` and `static/` (shipped as package data:
the pages load nothing from outside the service).
"""
