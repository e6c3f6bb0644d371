"""The notebook-style example of docs/guide/python.md runs as written: its
Python block, executed in a scratch folder, plots the force trace and the
error map and writes the figure and the results folder it names."""
import os
import re

import pytest

from conftest import ROOT

GUIDE = ROOT / "docs/guide/python.md"


def example_code() -> str:
    text = GUIDE.read_text(encoding="utf-8")
    section = text.split("## Example: a force trace and an error map", 1)[1]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert blocks, "no python block in the example section"
    return blocks[0]


def test_the_guide_example_plots_a_force_trace_and_an_error_map(tmp_path, monkeypatch):
    matplotlib = pytest.importorskip("matplotlib")
    pytest.importorskip("tqdm")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    (tmp_path / "examples").symlink_to(ROOT / "examples", target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(compile(example_code(), str(GUIDE), "exec"), scope)
    sim, opt = scope["sim"], scope["opt"]
    fig = scope["fig"]
    trace, emap = fig.axes[0], fig.axes[1]
    # The trace is the steps' force against time; the map the error grid on the stock.
    x, y = trace.lines[0].get_data()
    assert (x == sim.steps["t_s"]).all() and (y == sim.steps["force_n"]).all()
    assert emap.images[0].get_array().shape == sim.columns["error_um"].shape
    assert os.path.getsize("boss_contour.png") > 10_000
    assert (tmp_path / "out/boss/summary.json").exists()
    assert opt.summary.after is not None and opt.summary.after.steps > 0
    plt.close("all")
