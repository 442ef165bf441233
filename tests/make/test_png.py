"""cadcam's PNGs of its figures and sheets hold matplotlib's own pixels, without an alpha channel
where the figure is opaque."""
import io

import numpy as np
import pytest
from matplotlib.figure import Figure
from PIL import Image

from cadcam.make.png import save_png


def _figure(size=(3.3, 2.1), alpha: float = 1.0) -> Figure:
    """A small figure of lines and text, at a size whose pixel count rounds down at 110 dpi."""
    fig = Figure(figsize=size, layout="constrained")
    fig.patch.set_alpha(alpha)
    ax = fig.add_subplot()
    ax.semilogy(np.arange(20), np.exp(-np.arange(20)), marker=".", label="a line")
    ax.set_title("θ, μ and ‖d‖")
    ax.legend()
    return fig


def _matplotlibs(fig: Figure, dpi: float) -> Image.Image:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi)
    return Image.open(io.BytesIO(buffer.getvalue()))


@pytest.mark.parametrize("dpi", [110, 300])
def test_an_opaque_figure_is_written_with_matplotlibs_pixels_without_alpha(tmp_path, dpi):
    path = tmp_path / "figure.png"
    save_png(_figure(), path, dpi)
    ours, theirs = Image.open(path), _matplotlibs(_figure(), dpi)
    assert ours.mode == "RGB" and theirs.mode == "RGBA"
    assert ours.size == theirs.size
    np.testing.assert_array_equal(np.asarray(ours.convert("RGBA")), np.asarray(theirs))
    assert ours.info["Software"] == theirs.info["Software"]
    assert ours.info["dpi"] == pytest.approx(theirs.info["dpi"])


def test_a_figure_with_transparent_pixels_keeps_its_alpha(tmp_path):
    path = tmp_path / "figure.png"
    save_png(_figure(alpha=0.0), path, 110)
    ours = Image.open(path)
    assert ours.mode == "RGBA"
    np.testing.assert_array_equal(np.asarray(ours), np.asarray(_matplotlibs(_figure(alpha=0.0), 110)))


def test_the_png_is_written_whole_or_not_at_all(tmp_path, monkeypatch):
    path = tmp_path / "figure.png"
    path.write_bytes(b"the earlier file")

    def broken(self, *args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(Image.Image, "save", broken)
    with pytest.raises(OSError, match="disk full"):
        save_png(_figure(), path, 110)
    assert path.read_bytes() == b"the earlier file"
    assert [p.name for p in tmp_path.iterdir()] == ["figure.png"]


def test_a_laid_out_figure_is_drawn_once_and_keeps_its_layout_engine(tmp_path, monkeypatch):
    fig = _figure()
    engine = fig.get_layout_engine()
    draws = []
    monkeypatch.setattr(Figure, "draw", lambda self, renderer, draw=Figure.draw: draws.append(1) or draw(self, renderer))
    save_png(fig, tmp_path / "figure.png", 110)
    assert len(draws) == 1  # matplotlib's savefig alone draws a constrained figure twice
    assert fig.get_layout_engine() is engine and fig.dpi == 100 and type(fig.canvas).__name__ == "FigureCanvasBase"
