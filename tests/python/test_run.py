# dsnake.run(): the same positions as the command line, the output folder, the progress callback
# and two runs at once on two threads.
import json
import os
import pathlib
import subprocess
import sys
import threading

import numpy as np
import pytest

import dsnake


def read_contour(path):
    # final.txt: one "x y" line per vertex in the contour's order (framework/io/mesh_io.h), %.17g
    rows = [line.split() for line in pathlib.Path(path).read_text().splitlines()
            if line.strip() and not line.startswith("#")]
    return np.array(rows, dtype=np.float64)


def test_result_has_every_field(default_result):
    r = default_result
    n = r.vertices.shape[0]
    assert r.vertices.dtype == np.float64 and r.vertices.shape == (n, 2)
    assert r.faces is None and sorted(r.order.tolist()) == list(range(n))
    assert r.template_ids.shape == (n,)
    assert set(r.correspondence) == {"template_id", "initial", "final", "target", "error"}
    assert 0.9 < r.metrics["dice"] <= 1.0
    assert r.success is True and r.status in ("converged", "iteration_budget")
    assert r.trace["iteration"].shape == r.trace["total"].shape
    assert r.trace["iteration"][-1] == r.result["iterations"]
    assert r.config["dimension"] == 2
    provenance = r.result["provenance"]
    assert provenance["command_line"] == ["dsnake.run", "builtin:default"]
    assert provenance["build"]["version"] == r.result["version"] and provenance["inputs"] == {}


def test_positions_identical_to_the_command_line(dsnake_exe, tmp_path, default_result):
    out = tmp_path / "cli"
    subprocess.run([dsnake_exe, "run", "builtin:default", "--out", str(out), "--quiet"], check=True)
    cli = read_contour(out / "final.txt")
    ours = default_result.vertices[default_result.order]
    assert cli.shape == ours.shape
    np.testing.assert_allclose(ours, cli, rtol=0, atol=1e-12)
    expected = json.loads((out / "result.json").read_text())
    assert default_result.metrics == expected["metrics"]


def test_out_writes_the_command_lines_folder(dsnake_exe, tmp_path, default_result):
    cli, py = tmp_path / "cli", tmp_path / "py"
    subprocess.run([dsnake_exe, "run", "builtin:default", "--out", str(cli), "--quiet"], check=True)
    r = dsnake.run("builtin:default", out=py)
    assert sorted(os.listdir(py)) == sorted(os.listdir(cli))
    assert (py / "final.txt").read_text() == (cli / "final.txt").read_text()
    np.testing.assert_array_equal(r.vertices, default_result.vertices)


def test_report_writes_a_run_folders_report_and_refuses_other_folders(tmp_path):
    out = tmp_path / "run"
    dsnake.run("builtin:default", out=out)
    for name in ("report.html", "energy.png", "convergence.png"):
        (out / name).unlink()
    path = dsnake.report(out)
    assert path == str(out / "report.html")
    assert "DsnakeViewer" in (out / "report.html").read_text()
    assert (out / "energy.png").exists() and (out / "convergence.png").exists()
    with pytest.raises(dsnake.InputError, match="argument 'folder'"):
        dsnake.report(tmp_path)


def test_without_out_nothing_touches_the_disk(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    dsnake.run("builtin:classical")
    assert os.listdir(tmp_path) == []


def test_progress_sees_every_iteration(default_result):
    seen = []
    r = dsnake.run("builtin:default", progress=seen.append)
    assert [i["iteration"] for i in seen] == r.trace["iteration"].tolist()
    assert set(seen[0]) == {"phase", "iteration", "phase_iteration", "energy", "energy_terms", "max_move", "vertices"}
    np.testing.assert_array_equal(r.vertices, default_result.vertices)


class Stop(Exception):
    pass


def test_an_exception_in_progress_stops_the_run(tmp_path):
    calls = []

    def stop_at_five(info):
        calls.append(info["iteration"])
        if info["iteration"] == 5:
            raise Stop("enough")

    with pytest.raises(Stop, match="enough"):
        dsnake.run("builtin:default", out=tmp_path / "out", progress=stop_at_five)
    assert calls == [1, 2, 3, 4, 5]
    assert not (tmp_path / "out" / "result.json").exists()


def test_two_threads_at_once_give_the_sequential_results():
    configs = ["builtin:default", "builtin:classical"]
    sequential = [dsnake.run(c).vertices for c in configs]
    results = [None, None]

    def work(k):
        results[k] = dsnake.run(configs[k]).vertices

    threads = [threading.Thread(target=work, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for got, expected in zip(results, sequential):
        np.testing.assert_array_equal(got, expected)


def test_a_dict_config_runs_as_its_file(default_result):
    r = dsnake.run(default_result.config)
    np.testing.assert_array_equal(r.vertices, default_result.vertices)


def test_a_path_config(tmp_path, default_result):
    path = tmp_path / "experiment.json"
    path.write_text(json.dumps(default_result.config))
    np.testing.assert_array_equal(dsnake.run(path).vertices, default_result.vertices)


def test_the_one_liner_from_any_folder(tmp_path):
    code = "import dsnake; print(dsnake.run('builtin:default').metrics['dice'])"
    # The module folder as an absolute path (setup.sh's .pth file, or ctest's PYTHONPATH).
    package = os.path.dirname(os.path.abspath(dsnake.__file__))
    env = dict(os.environ, PYTHONPATH=os.path.dirname(package))
    out = subprocess.run(["/usr/bin/python3", "-c", code], cwd=tmp_path, env=env, check=True,
                         capture_output=True, text=True)
    assert 0.9 < float(out.stdout) <= 1.0
