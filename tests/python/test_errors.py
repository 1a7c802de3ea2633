# Errors: dsnake.Error and its subclasses, with the command line's one-line messages; bad input
# through Python names the argument or key and never crashes.
import copy
import math
import subprocess

import pytest

import dsnake


def test_the_classes():
    assert issubclass(dsnake.InputError, dsnake.Error)
    assert issubclass(dsnake.DivergenceError, dsnake.Error)
    assert issubclass(dsnake.Error, Exception)


def test_an_unknown_builtin_has_the_command_lines_message(dsnake_exe):
    cli = subprocess.run([dsnake_exe, "run", "builtin:nosuch", "--quiet"], capture_output=True, text=True)
    assert cli.returncode == 2
    with pytest.raises(dsnake.InputError) as e:
        dsnake.run("builtin:nosuch")
    assert cli.stderr.strip() == "dsnake: error: " + str(e.value)


def test_a_missing_file():
    with pytest.raises(dsnake.InputError, match="/no/such/experiment.json"):
        dsnake.run("/no/such/experiment.json")


def test_an_unknown_key_is_named(default_result):
    config = copy.deepcopy(default_result.config)
    config["energies"][0]["alphaa"] = 1
    with pytest.raises(dsnake.InputError, match=r"energies\[0\]\.alphaa"):
        dsnake.run(config)


def test_a_value_out_of_range_is_named(default_result):
    config = copy.deepcopy(default_result.config)
    config["phases"][0]["iterations"] = -3
    with pytest.raises(dsnake.InputError, match=r"phases\[0\]\.iterations"):
        dsnake.run(config)


def test_nan_in_a_dict_is_refused(default_result):
    config = copy.deepcopy(default_result.config)
    config["energies"][0]["weight"] = math.nan
    with pytest.raises(dsnake.InputError, match="config"):
        dsnake.run(config)


@pytest.mark.parametrize("config", [3, None, [1, 2], b"builtin:default", object()])
def test_a_config_of_the_wrong_type_names_the_argument(config):
    with pytest.raises(dsnake.InputError, match="config"):
        dsnake.run(config)


def test_a_dict_without_dimension():
    with pytest.raises(dsnake.InputError, match="dimension"):
        dsnake.run({"image": {}})


def test_progress_must_be_callable():
    with pytest.raises(dsnake.InputError, match="progress"):
        dsnake.run("builtin:default", progress=3)


def test_divergence_raises_with_the_result(default_result):
    config = copy.deepcopy(default_result.config)
    config["watchdog"] = {"max_move": 1e-6}
    with pytest.raises(dsnake.DivergenceError, match="the run diverged in phase") as e:
        dsnake.run(config)
    assert e.value.result.status == "diverged"
    assert e.value.result.success is False
