"""docs/notebooks/quickstart.ipynb runs from top to bottom in a Jupyter kernel (nbclient) on the test device, and
what it shows is there: the state's scatter plot and two rendered frames with boids on them."""

from __future__ import annotations

import base64
import io
from pathlib import Path

import numpy as np
import pytest
from helpers import foreground
from PIL import Image

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "notebooks" / "quickstart.ipynb"


@pytest.mark.gl
def test_the_quickstart_notebook_runs_and_shows_its_pictures(runtime, tmp_path):
    import nbformat
    from nbclient import NotebookClient

    notebook = nbformat.read(NOTEBOOK, as_version=4)
    where = {"metadata": {"path": str(tmp_path)}}  # the kernel's working folder
    NotebookClient(notebook, timeout=300, kernel_name="python3", resources=where).execute()
    pictures = [
        np.asarray(Image.open(io.BytesIO(base64.b64decode(output["data"]["image/png"]))).convert("RGB"))
        for cell in notebook.cells
        if cell.cell_type == "code"
        for output in cell.get("outputs", [])
        if "image/png" in output.get("data", {})
    ]
    assert len(pictures) == 3, f"{len(pictures)} pictures: the scatter plot, the rendered frame, the simulation itself"
    scatter, frame, itself = pictures
    assert (scatter < 128).mean() > 0.005, "the scatter plot is empty"
    for picture in (frame, itself):
        boids = foreground(picture, (0.192, 0.302, 0.475), 40).mean()  # the boids view's background colour
        assert picture.shape == (360, 640, 3) and 0.005 < boids < 0.8, f"a rendered frame: {boids:.3f} boids"
