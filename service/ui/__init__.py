"""The job service's web dashboard: server-rendered pages under `/ui` (see docs/service.md, Dashboard).

`routes.py` (the pages and `install_dashboard`), `views.py` (what a page shows of a job),
`rendering.py` (Jinja2 environment, static files), `templates/` and `static/` (shipped as package data:
the pages load nothing from outside the service).
"""
