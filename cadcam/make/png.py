"""PNG files of matplotlib figures, as cadcam writes its figures and sheets."""
from __future__ import annotations

import contextlib

import numpy as np

from ..files import atomic_path
from ..library_files import matplotlib_defaults

#: zlib's level of the PNGs written: the fast end of its scale. Measured on the 1-DOF spec's
#: 300-dpi sheet, without the alpha channel: 0.19 s and 433 kB against 0.35 s and 365 kB at
#: PNG's usual 6 (matplotlib's PNG, with the alpha channel: 0.49 s, 411 kB).
COMPRESS_LEVEL = 3


@matplotlib_defaults()
def save_png(fig, path, dpi: float) -> None:
    """Write the matplotlib figure ``fig`` to ``path`` as a PNG at ``dpi`` dots per inch,
    atomically: matplotlib's pixels and metadata, without the alpha channel where every pixel
    is opaque (a figure's own white background) and at :data:`COMPRESS_LEVEL`: the same
    image, encoded in less than half the time. A figure with a layout engine is laid out and
    drawn once, with one renderer (:func:`_drawn_once`)."""
    with atomic_path(path) as tmp, _drawn_once(fig, dpi):
        fig.savefig(_PngFile(tmp, fig, dpi), format="rgba", dpi=dpi)


@contextlib.contextmanager
def _drawn_once(fig, dpi: float):
    """Inside this block ``fig`` is on an Agg canvas, laid out by its layout engine
    (constrained layout) at ``dpi``, as saving it there lays it out, and has no engine; its
    canvas and engine are given back after it. Matplotlib saves a figure with an engine by
    drawing every artist twice, a dry draw that runs the layout and the draw that renders the
    pixels, each with a renderer of its own, which measures every text again; here the figure
    is drawn once, into the same pixels, and the draw measures its texts with the renderer that
    laid them out."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas, engine, before = fig.canvas, fig.get_layout_engine(), fig.dpi
    if not isinstance(canvas, FigureCanvasAgg):
        FigureCanvasAgg(fig)
    try:
        if engine is not None:
            fig.set_dpi(dpi)
            engine.execute(fig)
            fig.set_layout_engine(None)
        yield
    finally:
        fig.set_layout_engine(engine)
        fig.set_dpi(before)
        fig.set_canvas(canvas)


class _PngFile:
    """The file ``savefig(format="rgba")`` writes the pixels of ``fig`` to: it is handed the
    Agg renderer's buffer, without a copy, and writes it to ``path`` as a PNG."""

    def __init__(self, path, fig, dpi: float):
        self.path, self.fig, self.dpi = path, fig, dpi

    def seek(self, offset: int, whence: int = 0) -> int:  # what makes it a file to matplotlib
        return 0

    def write(self, pixels) -> None:
        import matplotlib
        from PIL import Image, PngImagePlugin

        # the canvas drawing the figure now, as it sized its renderer
        size = self.fig.canvas.get_width_height(physical=True)
        image = Image.frombuffer("RGBA", size, pixels, "raw", "RGBA", 0, 1)
        if np.frombuffer(pixels, np.uint8)[3::4].min() == 255:
            image = image.convert("RGB")
        info = PngImagePlugin.PngInfo()  # matplotlib's own
        info.add_text("Software", f"Matplotlib version{matplotlib.__version__}, https://matplotlib.org/")
        image.save(self.path, format="png", pnginfo=info, dpi=(self.dpi, self.dpi), compress_level=COMPRESS_LEVEL)
