"""The corner plots' PDF keeps a copy of each rasterised panel, not a view of the whole figure's
raster buffer (roboball.figures.friction._pdf_images_copied): the same bytes, a fraction of the
memory."""
import io

import numpy as np

from roboball.figures.friction import _pdf_images_copied
from roboball.figures.style import plt


def _pdf(seen: list) -> bytes:
    rng = np.random.default_rng(0)
    fig, axes = plt.subplots(3, 3, figsize=(9, 9), layout="none")
    for ax in axes.flat:
        ax.plot(*rng.standard_normal((2, 2000)), ".", ms=1, rasterized=True)
    buf = io.BytesIO()
    fig.savefig(buf, format="pdf", metadata={"CreationDate": None, "Producer": None, "Creator": None})
    plt.close(fig)
    return buf.getvalue()


def test_the_pdf_holds_copies_of_its_rasterised_panels_and_the_same_bytes(monkeypatch):
    from matplotlib.backends import backend_pdf
    seen = []
    spy = backend_pdf.PdfFile.imageObject

    def record(self, image):
        seen.append(image)
        return spy(self, image)

    monkeypatch.setattr(backend_pdf.PdfFile, "imageObject", record)
    plain = _pdf(seen)
    views, seen[:] = list(seen), []
    with _pdf_images_copied():
        copied = _pdf(seen)
    assert copied == plain
    assert len(views) == len(seen) == 9
    # matplotlib's: a view of a buffer the size of the whole figure; ours: each panel's own pixels
    held_plain = sum(v.base.nbytes if v.base is not None else v.nbytes for v in views)
    held_copied = sum(c.nbytes for c in seen if c.base is None)
    assert all(c.base is None for c in seen)
    assert held_copied < held_plain / 5
    assert backend_pdf.PdfFile.imageObject is record          # restored after the save
