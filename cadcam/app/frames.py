"""The mechanism moving over its range on the design page: frames drawn when first shown and
kept (:func:`cadcam.outputs.plots.pose_frames`), as PNG images."""
from __future__ import annotations

import io

from ..library_files import matplotlib_defaults
from ..outputs.plots import pose_frames
from ..verify.evaluate import Evaluation

#: Joint angles the page's player steps through over the range.
FRAMES = 24
#: Resolution of a frame [dots per inch].
FRAME_DPI = 100


class Frames:
    """The frames of one evaluated design."""

    def __init__(self, ev: Evaluation, count: int = FRAMES):
        self.count, self._frame = pose_frames(ev, count)
        self._png: dict[int, bytes] = {}

    @matplotlib_defaults()
    def png(self, i: int) -> bytes:
        """Frame ``i`` (0 … count − 1) as PNG bytes."""
        i = max(0, min(int(i), self.count - 1))
        if i not in self._png:
            buffer = io.BytesIO()
            self._frame(i).savefig(buffer, format="png", dpi=FRAME_DPI)
            self._png[i] = buffer.getvalue()
        return self._png[i]
