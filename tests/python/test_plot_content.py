"""What runner/plot.py draws, read from the matplotlib figure (panels, axes, plotted data), not from pixels. The run
files are written here with h5py in grains' layout (observables/NAME/{step,time,value}), so no binary is needed."""
import importlib.util
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT

h5py = pytest.importorskip("h5py")
pytest.importorskip("matplotlib")

spec = importlib.util.spec_from_file_location("plot_tool", ROOT / "runner" / "plot.py")
plot_tool = importlib.util.module_from_spec(spec)
spec.loader.exec_module(plot_tool)


def run_file(path, observables, name="scene", scene=""):
    """An H5MD-like run file with these observables ({name: values}), recorded at steps 0, 10, 20, ..., and the scene
    `[scene] name` with the TOML `scene` after it."""
    with h5py.File(path, "w") as f:
        f.create_group("parameters").attrs["scene.toml"] = f'[scene]\nname = "{name}"\n{scene}'
        for key, values in observables.items():
            values = np.asarray(values, float)
            group = f.create_group(f"observables/{key}")
            group["step"] = np.arange(len(values)) * 10
            group["time"] = np.arange(len(values)) * 0.5
            group["value"] = values
    return path


def drawn(path, monkeypatch, *args):
    """The figure plot.py's main() draws of `path` with these options."""
    import matplotlib.pyplot as plt

    figures = []
    monkeypatch.setattr(plot_tool, "plot", lambda series, out, *rest: figures.append(plot_tool.figure(series, *rest)))
    assert plot_tool.main([str(path), "-o", str(path.with_suffix(".png")), *args]) == 0
    plt.close("all")
    return figures[0]


def panel(fig, title_start):
    found = [ax for ax in fig.axes if ax.get_title().startswith(title_start)]
    assert len(found) == 1, [ax.get_title() for ax in fig.axes]
    return found[0]


def test_virial_ratio_of_a_cold_start_on_a_log_axis(tmp_path, monkeypatch):
    """Q starts at 0 (the cloud at rest) and decays over decades after its peak: on a linear axis (a zero must not bar
    the log axis) the decay and any second peak would be a flat line at 0."""
    q = [0.0, 1e-3, 0.1, 0.43, 0.01, 1e-4, 3e-4, 1e-5, 5e-6, 6e-6, 5e-6]
    path = run_file(tmp_path / "cloud.h5", {"virial_ratio": q, "time_over_free_fall": np.linspace(0, 3, len(q)),
                                            "largest_cluster_fraction": np.linspace(0.001, 1, len(q)),
                                            "cluster_index": np.linspace(1, 0.001, len(q))})
    fig = drawn(path, monkeypatch)
    ax = panel(fig, "Q = K / |W|")
    assert ax.get_yscale() == "log" and "zeros not drawn" in ax.get_title()
    assert np.array_equal(ax.lines[0].get_ydata(), q)
    assert fig.axes[-1].get_xlabel() == "t / t_ff"   # a gravity scene: against the free-fall time by default


def test_a_series_mostly_zero_stays_linear(tmp_path, monkeypatch):
    """A lone collision: contacts and elastic energy are zero but for the contact, and read better on a linear axis;
    the kinetic energy, never zero, spanning more than three decades, goes on a log axis."""
    elastic = np.zeros(50)
    elastic[20:25] = [1e-9, 0.05, 0.14, 0.05, 1e-9]
    kinetic = np.full(50, 0.25)
    kinetic[20:25] = [0.2, 0.01, 1e-4, 0.01, 0.07]
    path = run_file(tmp_path / "collision.h5", {"kinetic_energy": kinetic, "elastic_energy": elastic,
                                                "contacts": elastic > 0, "max_overlap_ratio": elastic * 0.3})
    fig = drawn(path, monkeypatch)
    assert panel(fig, "elastic energy").get_yscale() == "linear"
    assert panel(fig, "kinetic energy").get_yscale() == "log"
    assert "units" in fig.axes[-1].get_xlabel()   # the time's units named: the scene's own


def test_a_cell_scene_shows_its_pressure_against_the_target_and_its_packing(tmp_path, monkeypatch):
    """A pressure-controlled scene was drawn as its energies, contacts and overlap (runner/main.sh), saying nothing of
    the pressure it is held at or the packing it reaches."""
    target = np.full(8, 0.01)
    measured = [0.0, 0.02, 0.015, 0.011, 0.0102, 0.0099, 0.01, 0.01]
    path = run_file(tmp_path / "cell.h5", {"pressure_reduced": measured, "pressure_target": target,
                                           "solid_fraction": np.linspace(0.36, 0.5, 8), "coordination": np.linspace(0, 3, 8),
                                           "kinetic_energy": np.linspace(1, 0.1, 8), "contacts": np.arange(8),
                                           "elastic_energy": np.linspace(0, 1, 8), "max_overlap_ratio": np.linspace(0, 1e-3, 8)})
    fig = drawn(path, monkeypatch)
    assert [ax.get_title() for ax in fig.axes] == ["P* = a P / F0", "solid fraction Phi", "coordination number z",
                                                   "kinetic energy K"]
    pressure = fig.axes[0]
    assert [line.get_label() for line in pressure.lines] == ["measured", "target"]
    assert np.array_equal(pressure.lines[0].get_ydata(), measured)
    assert np.array_equal(pressure.lines[1].get_ydata(), target)


def test_collision_log_scene_shows_the_adhesive_fraction(tmp_path, monkeypatch):
    path = run_file(tmp_path / "medea.h5", {"kinetic_energy": [2, 1.9, 1.8], "contacts": [0, 2, 1],
                                            "collision_count": [0, 1, 3], "adhesive_collision_fraction": [np.nan, 0, 1 / 3],
                                            "elastic_energy": [0, 1e-3, 0]})
    fig = drawn(path, monkeypatch)
    assert fig.axes[-1].get_title() == "adhesive collisions / collisions"


def test_panels_without_values_say_so(tmp_path, monkeypatch):
    """A series with no finite value (NaN throughout, as D_f before any cluster) or no records is an empty panel:
    it says which."""
    path = run_file(tmp_path / "nan.h5", {"fractal_dimension": [np.nan] * 4, "kinetic_energy": [1, 2, 3, 4]})
    fig = drawn(path, monkeypatch, "--observables", "fractal_dimension,kinetic_energy")
    assert [t.get_text() for t in fig.axes[0].texts] == ["no finite values (NaN)"]
    assert len(fig.axes[1].texts) == 0
    empty = plot_tool.figure({"kinetic_energy": (np.array([]), np.array([]))})
    assert [t.get_text() for t in empty.axes[0].texts] == ["no values yet"]


def test_main_sh_draws_what_plot_py_draws_by_default(grains_bin, root, tmp_path):
    """runner/main.sh chose the panels itself (energies for every scene without gravity); now plot.py's defaults, by the
    kind of scene, are the one choice: main.sh's picture of a cell scene is plot.py's, byte for byte."""
    env = dict(os.environ, GRAINS_BUILD=str(pathlib.Path(grains_bin).parents[1]),
               GRAINS_VENV=str(pathlib.Path(sys.executable).parents[1]), OMP_WAIT_POLICY="passive")
    if not (pathlib.Path(env["GRAINS_VENV"]) / "bin" / "python").exists():
        pytest.skip("not run from the project's virtual environment")
    out = tmp_path / "cell.h5"
    r = subprocess.run(["bash", str(root / "runner" / "main.sh"), str(root / "models" / "consolidation.toml"), "--out",
                        str(out), "--set", "particles.count=100", "--set", "time.steps=300", "--set",
                        "analysis.elastic_moduli=false", "--set", "run.threads=1", "--quiet"],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    again = tmp_path / "again.png"
    p = subprocess.run([sys.executable, str(root / "runner" / "plot.py"), str(out), "-o", str(again)], capture_output=True,
                       text=True)
    assert p.returncode == 0, p.stderr
    assert out.with_suffix(".png").read_bytes() == again.read_bytes()


def test_initial_states_legend_says_what_an_open_point_is(tmp_path):
    """A sample not in equilibrium is drawn open (docs: type 1 with M_c = m, two of four); the legend said only
    "grains"."""
    sys.path.insert(0, str(ROOT / "runner"))
    import initial_states

    final = {"type1": [{"phi": "0.708", "reached": "1"}, {"phi": "0.702", "reached": "0"}]}
    fig = initial_states.plot(final, tmp_path / "states.png")
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "grains, one per sample (open: not in equilibrium)" in labels and "paper (±2 bars)" in labels
    open_points = [line for line in fig.axes[0].lines if line.get_markerfacecolor() == "none"]
    assert [line.get_ydata()[0] for line in open_points] == [0.702]


@pytest.mark.parametrize("scene, label", [("dimension = 2\n", "P* = a P / F0"), ("dimension = 3\n", "P* = a² P / F0"),
                                          ("dimension = 2\n[cell]\nforce_unit = 0\n", "P* = P / K_N"),
                                          ("dimension = 3\n[cell]\nforce_unit = 0\n", "P* = a P / k_n")])
def test_the_pressure_panel_says_what_p_star_is_in_the_scene(tmp_path, monkeypatch, scene, label):
    """P* is a P / F0 in 2D, a^2 P / F0 in 3D and P a^(D-2) / k_n in a cohesionless cell (scene reference,
    cell.pressure): every scene's panel read a P / F0."""
    path = run_file(tmp_path / "cell.h5", {"pressure_reduced": [1e-5, 1e-5], "solid_fraction": [0.36, 0.4]}, scene=scene)
    assert drawn(path, monkeypatch).axes[0].get_title() == label


def test_a_programme_is_drawn_as_its_trace_with_the_stage_records_as_dots(tmp_path, monkeypatch):
    """grains consolidate records one full record per stage (observables/NAME) and its trace within the stages
    (grains/trace/NAME, programme.trace_every): the default panels draw the trace, the stages' course, with the
    stage records as dots, the last one too. The first record is the initial state, not a stage's end: drawn and
    labelled apart (all were "end of a stage")."""
    path = tmp_path / "stages.h5"
    with h5py.File(path, "w") as f:
        f.create_group("parameters").attrs["scene.toml"] = '[scene]\nname = "programme"\n[cell]\nenabled = true\n'
        group = f.create_group("observables")
        group.attrs["complete_to_step"] = 300
        stage_steps, trace_steps = np.array([0, 100, 300]), np.arange(10, 301, 10)
        for name, ends, course in (("pressure_reduced", [0.0, 0.01, 0.0133], 0.01 + 0 * trace_steps),
                                   ("pressure_target", [0.01, 0.01, 0.0133], 0.01 + 0 * trace_steps),
                                   ("solid_fraction", [0.36, 0.45, 0.47], 0.36 + trace_steps / 3000),
                                   ("coordination", [0.0, 3.0, 3.1], 0 * trace_steps + 3.0),
                                   ("kinetic_energy", [1.0, 0.1, 0.01], 1 / trace_steps),
                                   ("B", [0.0, 1.0, 2.0], None)):
            for where, steps, values in ((group, stage_steps, ends), (f.require_group("grains/trace"), trace_steps, course)):
                if values is not None:
                    g = where.create_group(name)
                    g["step"], g["time"], g["value"] = steps, steps * 0.5, np.asarray(values, float)
    fig = drawn(path, monkeypatch)
    assert [ax.get_title() for ax in fig.axes] == ["P* = a P / F0", "solid fraction Phi", "coordination number z",
                                                   "kinetic energy K"]
    phi = fig.axes[1]
    course, initial, ends = phi.lines[:3]
    assert np.array_equal(course.get_xdata(), trace_steps * 0.5)
    assert np.allclose(course.get_ydata(), 0.36 + trace_steps / 3000)
    assert initial.get_label() == "initial state" and initial.get_marker() == "s"
    assert list(initial.get_xdata()) == [0.0] and list(initial.get_ydata()) == [0.36]
    assert ends.get_label() == "end of a stage" and ends.get_marker() == "o"
    assert np.array_equal(ends.get_xdata(), [50.0, 150.0]) and np.array_equal(ends.get_ydata(), [0.45, 0.47])
    assert [line.get_label() for line in fig.axes[0].lines] == ["measured", "initial state", "end of a stage", "target"]
    assert [t.get_text() for t in phi.get_legend().get_texts()] == ["initial state", "end of a stage"]


def test_one_stage_of_a_programme(tmp_path, monkeypatch):
    """--stage N: the trace of stage N, from the previous stage's end row to its own, and the stage records at its
    start and end (stage 0's start the initial state); a stage the file does not hold, or a file without a trace, is
    refused naming the option."""
    path = tmp_path / "stages.h5"
    with h5py.File(path, "w") as f:
        f.create_group("parameters").attrs["scene.toml"] = '[scene]\nname = "programme"\n[cell]\nenabled = true\n'
        group = f.create_group("observables")
        group.attrs["complete_to_step"] = 300
        course = np.arange(10, 301, 10)   # a row at each stage's end (steps 100 and 300) too
        for where, steps in ((group, np.array([0, 100, 300])), (f.require_group("grains/trace"), course)):
            for name in ("pressure_reduced", "pressure_target", "solid_fraction", "coordination", "kinetic_energy"):
                g = where.create_group(name)
                g["step"], g["time"], g["value"] = steps, steps * 0.5, 0.3 + steps / 1000
        g = f.create_group("grains/trace/stage")
        g["step"], g["time"], g["value"] = course, course * 0.5, (course > 100) * 1.0
    fig = drawn(path, monkeypatch, "--stage", "1")
    phi = panel(fig, "solid fraction Phi")
    assert np.array_equal(phi.lines[0].get_xdata(), np.arange(100, 301, 10) * 0.5)   # steps 100 .. 300
    assert [line.get_label() for line in phi.lines] == ["_nolegend_", "end of a stage"]   # no initial state in stage 1
    assert np.array_equal(phi.lines[1].get_xdata(), [50.0, 150.0])   # the stage records at steps 100 and 300
    assert fig.get_suptitle().endswith("stage 1")
    phi = panel(drawn(path, monkeypatch, "--stage", "0"), "solid fraction Phi")
    assert [(line.get_label(), list(line.get_xdata())) for line in phi.lines[1:]] == [("initial state", [0.0]),
                                                                                       ("end of a stage", [50.0])]
    for args, message in ((["--stage", "3"], "--stage 3: "), (["--stage", "-1"], "--stage -1: ")):
        r = subprocess.run([sys.executable, ROOT / "runner/plot.py", path, "-o", tmp_path / "x.png", *args],
                           capture_output=True, text=True)
        assert r.returncode == 2 and message in r.stderr and "stages 0 to 2" in r.stderr, r.stderr
    plain = run_file(tmp_path / "plain.h5", {"solid_fraction": [0.3, 0.4]})
    r = subprocess.run([sys.executable, ROOT / "runner/plot.py", plain, "-o", tmp_path / "y.png", "--stage", "0"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "--stage needs one" in r.stderr, r.stderr


def test_a_run_read_as_a_flush_comes_is_cut_where_every_series_is_whole(tmp_path, monkeypatch):
    """A run still writing its file may flush between plot.py's reading of the rows and of /observables@complete_to_step:
    the mark is then past a series' last row read. Every observable is cut at the step all of them hold (as before the
    trace came), so that one drawn against another (--x) has its rows; the trace of a programme is cut on its own."""
    path = run_file(tmp_path / "live.h5", {"time_over_free_fall": [0.0, 0.1, 0.2, 0.3], "largest_cluster_fraction": [0.1, 0.2, 0.3]})
    with h5py.File(path, "r+") as f:
        f["observables"].attrs["complete_to_step"] = 30   # the fourth row's step, which one series does not hold
    fig = drawn(path, monkeypatch, "--observables", "largest_cluster_fraction", "--x", "time_over_free_fall")
    assert np.array_equal(fig.axes[0].lines[0].get_xdata(), [0.0, 0.1, 0.2])


def test_a_finished_programme_has_no_stage_under_way(tmp_path, monkeypatch):
    """--stage N of a complete programme: its stages are those of its records after the initial state's; the one
    after the last is refused (it drew the last stage record alone), while a file still written has it under way."""
    path = tmp_path / "stages.h5"
    with h5py.File(path, "w") as f:
        f.create_group("parameters").attrs["scene.toml"] = '[scene]\nname = "programme"\n[cell]\nenabled = true\n'
        f.create_group("grains").attrs["status"] = np.bytes_("complete")
        f.create_group("observables").attrs["complete_to_step"] = 300
        for where, steps in ((f["observables"], np.array([0, 100, 300])),
                             (f.require_group("grains/trace"), np.setdiff1d(np.arange(10, 300, 10), [100]))):
            for name in ("pressure_reduced", "pressure_target", "solid_fraction", "coordination", "kinetic_energy"):
                g = where.create_group(name)
                g["step"], g["time"], g["value"] = steps, steps * 0.5, 0.3 + steps / 1000
    assert panel(drawn(path, monkeypatch, "--stage", "1"), "solid fraction").lines[1].get_xdata().tolist() == [50.0, 150.0]
    r = subprocess.run([sys.executable, ROOT / "runner/plot.py", path, "-o", tmp_path / "x.png", "--stage", "2"],
                       capture_output=True, text=True)
    assert r.returncode == 2 and "--stage 2: " in r.stderr and "stages 0 to 1 (2 finished)" in r.stderr, r.stderr
    with h5py.File(path, "r+") as f:
        f["grains"].attrs["status"] = np.bytes_("running")
    assert panel(drawn(path, monkeypatch, "--stage", "2"), "solid fraction").lines[1].get_xdata().tolist() == [150.0]


def test_an_element_without_a_course_in_time_is_left_out_and_named_when_asked_for(tmp_path, monkeypatch):
    """H5MD's time-independent element (a plain dataset) and a group without its step must not end the plot in a
    traceback. They are not offered; asked for by name, the refusal says why."""
    path = run_file(tmp_path / "odd.h5", {"kinetic_energy": [1, 2, 3, 4]})
    with h5py.File(path, "r+") as f:
        f["observables/constant"] = np.arange(3.0)
        f["observables/stepless/value"] = np.arange(3.0)
        f["observables/stepless/time"] = np.arange(3.0)
    fig = drawn(path, monkeypatch)
    assert [ax.get_title() for ax in fig.axes] == ["kinetic energy K"]
    asked = subprocess.run([sys.executable, ROOT / "runner/plot.py", path, "--observables", "constant,stepless", "-o",
                            tmp_path / "odd.png"], capture_output=True, text=True)
    assert asked.returncode == 2 and "Traceback" not in asked.stderr, asked.stderr
    assert "no observable constant, stepless with a course in time" in asked.stderr, asked.stderr
    with h5py.File(path, "r+") as f:
        del f["observables/kinetic_energy"]
    alone = subprocess.run([sys.executable, ROOT / "runner/plot.py", path, "-o", tmp_path / "odd.png"], capture_output=True,
                           text=True)
    assert alone.returncode == 2 and "has no observables with a course in time" in alone.stderr, alone.stderr
