"""A run as data: the settings table, run.json, preparing and executing a run with its outputs,
atlases and exported web pages."""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "SETTINGS": "morphogen.runs.settings",
    "RunConfig": "morphogen.runs.config",
    "load_run_file": "morphogen.runs.config",
    "Prepared": "morphogen.runs.prepare",
    "write_outputs": "morphogen.runs.outputs",
    "compute_atlas": "morphogen.runs.atlas",
    "Atlas": "morphogen.runs.atlas",
    "Axis": "morphogen.runs.atlas",
    "export_page": "morphogen.runs.web_page",
})
