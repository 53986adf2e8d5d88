"""The notebook bridge/examples/notebooks/platoon.ipynb runs top to bottom, as a researcher
would run it: in a Jupyter kernel on this interpreter (with the `platoon` package installed, as
.ci/run installs it into the bridge's venv), started in an empty directory outside the
checkout. It must raise nowhere, show what it says it shows, and write only into its
temporary directory.
"""

import json
import os
import pathlib
import sys
import time

import nbformat
import pytest
from jupyter_client.kernelspec import KernelSpecManager
from jupyter_client.manager import AsyncKernelManager
from nbclient import NotebookClient

import platoon

REPO = pathlib.Path(__file__).resolve().parents[2]
NOTEBOOK = REPO / "bridge" / "examples" / "notebooks" / "platoon.ipynb"
KERNEL = "platoon-test"


def kernel_manager(tmp_path):
    """A kernel on this very interpreter, whatever kernelspecs the machine has: a kernelspec of
    our own in a directory only this manager searches."""
    spec = tmp_path / "kernels" / KERNEL
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(
        json.dumps(
            {
                "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
                "display_name": f"Python ({sys.executable})",
                "language": "python",
            }
        )
    )
    ksm = KernelSpecManager(kernel_dirs=[str(spec.parent)], ensure_native_kernel=False)
    return AsyncKernelManager(kernel_name=KERNEL, kernel_spec_manager=ksm)


def outputs_text(cell):
    """Everything a code cell printed or displayed as text."""
    parts = []
    for o in cell.get("outputs", []):
        if o.output_type == "stream":
            parts.append(o.text)
        elif o.output_type in ("execute_result", "display_data"):
            parts.append(o.data.get("text/plain", ""))
            parts.append(o.data.get("text/html", ""))
        elif o.output_type == "error":
            parts.append(f"{o.ename}: {o.evalue}")
    return "".join(parts)


def test_the_notebook_is_committed_without_outputs():
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    assert nb.nbformat == 4
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, cell.id


def test_the_notebook_finds_the_checkout_from_a_directory_inside_it(monkeypatch):
    """Its first code cell walks up from the working directory (here the notebook's own, where
    Jupyter starts it) to the checkout's root."""
    nb = nbformat.read(NOTEBOOK, as_version=4)
    setup = next(c for c in nb.cells if c.cell_type == "code")
    # Only the root finder: the cell's imports and definitions, without the temporary directory.
    source = setup.source.split("OUT = ")[0]
    for cwd in (NOTEBOOK.parent, REPO / "crates", REPO):
        monkeypatch.chdir(cwd)
        scope = {}
        exec(compile(source, "setup", "exec"), scope)
        assert scope["ROOT"] == REPO, cwd
        assert scope["find_checkout"](pathlib.Path(cwd)) == REPO, cwd


def test_the_notebook_runs_top_to_bottom(tmp_path):
    cwd = tmp_path / "cwd"
    tmp = tmp_path / "tmp"
    cwd.mkdir()
    tmp.mkdir()
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = NotebookClient(
        nb,
        km=kernel_manager(tmp_path),
        timeout=600,
        startup_timeout=120,
        allow_errors=False,
        resources={"metadata": {"path": str(cwd)}},
    )
    # The kernel's temporary files (the notebook's OUT) go under tmp_path, so this test sees
    # them and pytest removes them.
    env = dict(os.environ, TMPDIR=str(tmp))
    start = time.monotonic()
    # Raises CellExecutionError naming the cell that raised; shuts the kernel down after.
    client.execute(env=env, cleanup_kc=True)
    took = time.monotonic() - start
    print(f"the notebook ran in {took:.1f} s")

    cells = {c.id: c for c in nb.cells}
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert all(c.execution_count is not None for c in code), "a cell did not run"
    errors = [c.id for c in code if any(o.output_type == "error" for o in c.outputs)]
    assert errors == [], errors

    # The paper run's safety class, as the package gives it here, is what the notebook shows.
    expected = platoon.run("paper").summary["safety"]["class"]
    assert f"safety class: {expected}" in outputs_text(cells["summary"])

    # Figures shown: Fig. 6 and 7 of the run, two heatmaps of the campaign.
    def pngs(cell_id):
        return sum("image/png" in o.get("data", {}) for o in cells[cell_id].outputs)

    assert pngs("figs") == 2
    assert pngs("heatmaps") == 2

    # The static rule broadcasts more than the paper's dynamic one (the point of the edit).
    compare = outputs_text(cells["edit-compare"])
    assert "the static rule broadcasts" in compare, compare
    ratio = float(compare.split("broadcasts ")[1].split("x")[0])
    assert ratio > 1.0, compare

    # The campaign ran every cell of its small grid and its pivot table has the grid's shape.
    assert "33 cells, 33 ok, 0 failed" in outputs_text(cells["campaign-run"])
    pivot = outputs_text(cells["pivot"])
    assert "dos.onset_s" in pivot and "dos.duration_s" in pivot

    # The design check prints its verdict on the tau range.
    design = outputs_text(cells["design"])
    assert "stable over the tau range: True" in design, design
    assert "smallest beta1/beta2 for which LMI (13) holds" in design, design

    # Written only into its temporary directory: the working directory stays empty, and the
    # run and the campaign are under the kernel's TMPDIR.
    assert list(cwd.iterdir()) == []
    (out,) = tmp.glob("platoon-notebook-*")
    assert (out / "paper" / "fig6.png").is_file()
    assert (out / "dos-timing" / "cells.csv").is_file()
    assert (out / "dos-timing" / "plots" / "heatmap_safety_class.png").is_file()
