"""The web app (``morphogen serve``): FastAPI routes and static pages over the same engine."""
