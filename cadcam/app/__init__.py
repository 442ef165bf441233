"""``cadcam app``: a local design page (Panel on the Bokeh server) over the engine.

:mod:`cadcam.app.form` generates the form and its sliders from the spec reader's declarations,
:mod:`cadcam.app.state` holds the spec, the edits and the designs (no page),
:mod:`cadcam.app.history` the designs made, to undo and redo (no page),
:mod:`cadcam.app.latest` serves the newest of the requests a moving slider makes (no page),
:mod:`cadcam.app.parts` makes the spring catalogue table and its lights (no page),
:mod:`cadcam.app.tables` reads and edits a tabulated target (no page), :mod:`cadcam.app.uploads`
writes an upload of a spec with its CSV files (no page), :mod:`cadcam.app.views` makes the numbers
the live view draws (no page), :mod:`cadcam.app.live` draws them in Bokeh plots,
:mod:`cadcam.app.page` shows them all, :mod:`cadcam.app.hosts` holds the server to the names it
serves on; Panel loads only with the page (``pip install cadcam[app]``).
"""
from __future__ import annotations


def serve(path: str | None = None, port: int = 5006, address: str = "127.0.0.1", show: bool = True) -> None:
    """Serve the design page (:func:`cadcam.app.page.serve`)."""
    from .page import serve as serve_page

    serve_page(path, port=port, address=address, show=show)
