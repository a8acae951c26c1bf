"""Mechanisms from outside the package: entry points, 'module:Class' paths, config search paths."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import EntryPoint
from pathlib import Path

import pytest

import kinematics
from kinematics import MECHANISMS, resolve_mechanism
from kinematics.plugins import (
    CONFIG_ENTRY_POINT_GROUP,
    ENTRY_POINT_GROUP,
    PluginError,
    config_search_paths,
    entry_point_mechanisms,
)
from kinematics.rpr2 import RPR2

ROOT = Path(__file__).resolve().parents[1]


class Renamed(RPR2):
    """An external-looking mechanism (importable by path: tests.test_plugins:Renamed)."""

    name = "renamed_rpr2"


class TakesABuiltinName(RPR2):
    name = "rpr2"


def ep(name: str, value: str, group: str = ENTRY_POINT_GROUP) -> EntryPoint:
    return EntryPoint(name=name, value=value, group=group)


def test_entry_points_join_the_builtins():
    found = entry_point_mechanisms(MECHANISMS.builtins, [ep("renamed_rpr2", "tests.test_plugins:Renamed")])
    assert found == {"renamed_rpr2": Renamed}


@pytest.mark.parametrize(
    "entry, message",
    [
        (
            ep("rpr2", "tests.test_plugins:TakesABuiltinName"),
            "entry point 'rpr2 = tests.test_plugins:TakesABuiltinName' (group pm_design.mechanisms): name 'rpr2' is the "
            "built-in mechanism kinematics.rpr2:RPR2; rename the entry point and its class's name",
        ),
        (
            ep("gone", "no_such_package.mech:Gone"),
            "entry point 'gone = no_such_package.mech:Gone' (group pm_design.mechanisms): cannot load: "
            "ModuleNotFoundError: No module named 'no_such_package'",
        ),
        (
            ep("missing", "tests.test_plugins:Missing"),
            "entry point 'missing = tests.test_plugins:Missing' (group pm_design.mechanisms): cannot load: "
            "AttributeError: module 'tests.test_plugins' has no attribute 'Missing'",
        ),
        (
            ep("ep", "tests.test_plugins:ep"),
            "entry point 'ep = tests.test_plugins:ep' (group pm_design.mechanisms): <function ep at",
        ),
        (
            ep("other", "tests.test_plugins:Renamed"),
            "entry point 'other = tests.test_plugins:Renamed' (group pm_design.mechanisms): the entry point's name must "
            "equal Renamed.name ('renamed_rpr2')",
        ),
        (
            ep("base", "kinematics.base:Mechanism"),
            "entry point 'base = kinematics.base:Mechanism' (group pm_design.mechanisms): Mechanism is abstract",
        ),
    ],
)
def test_a_bad_entry_point_is_one_line_naming_it(entry, message):
    with pytest.raises(PluginError) as info:
        entry_point_mechanisms(MECHANISMS.builtins, [entry])
    assert str(info.value).startswith(message)
    assert "\n" not in str(info.value)


def test_two_entry_points_of_one_name():
    with pytest.raises(PluginError, match=r"name 'renamed_rpr2' is also declared by entry point 'renamed_rpr2 = "):
        entry_point_mechanisms(
            MECHANISMS.builtins,
            [ep("renamed_rpr2", "tests.test_plugins:Renamed"), ep("renamed_rpr2", "tests.test_plugins:Renamed")],
        )


def test_resolve_names_and_paths():
    assert resolve_mechanism("h4") is MECHANISMS["h4"]
    assert resolve_mechanism("tests.test_plugins:Renamed") is Renamed
    assert resolve_mechanism("kinematics.rpr2:RPR2") is RPR2  # a built-in by path is the same class


@pytest.mark.parametrize(
    "path, message",
    [
        ("nope", "unknown mechanism 'nope'; allowed: " + ", ".join(MECHANISMS.builtins)),
        (
            "no_such_package.mech:X",
            "mechanism path 'no_such_package.mech:X': no module named 'no_such_package' "
            "(is its package installed in this environment?)",
        ),
        (
            "kinematics.no_such_module:X",
            "mechanism path 'kinematics.no_such_module:X': no module named 'kinematics.no_such_module'",
        ),
        (
            "kinematics.rpr2:Missing",
            "mechanism path 'kinematics.rpr2:Missing': module 'kinematics.rpr2' has no attribute 'Missing'",
        ),
        (
            "kinematics.base:DesignVariable",
            "mechanism path 'kinematics.base:DesignVariable': <class "
            "'kinematics.base.DesignVariable'> is not a subclass of "
            "kinematics.base.Mechanism",
        ),
        (
            "tests.test_plugins:TakesABuiltinName",
            "mechanism path 'tests.test_plugins:TakesABuiltinName': its name 'rpr2' is taken by kinematics.rpr2:RPR2",
        ),
        ("kinematics rpr2:RPR2", "mechanism path 'kinematics rpr2:RPR2': expected 'package.module:Class'"),
    ],
)
def test_resolve_errors_are_one_line(path, message):
    with pytest.raises(ValueError) as info:
        resolve_mechanism(path)
    assert str(info.value).startswith(message) and "\n" not in str(info.value)


def test_config_search_paths():
    assert config_search_paths([ep("p", "pipeline", CONFIG_ENTRY_POINT_GROUP)]) == ["pkg://pipeline"]
    with pytest.raises(
        PluginError,
        match=r"'nope = no_such_package.conf' .*: cannot find package "
        r"'no_such_package.conf': ModuleNotFoundError",
    ):
        config_search_paths([ep("nope", "no_such_package.conf", CONFIG_ENTRY_POINT_GROUP)])
    with pytest.raises(PluginError, match="the value must be a package name such as 'my_package.conf'"):
        config_search_paths([ep("obj", "pipeline:config", CONFIG_ENTRY_POINT_GROUP)])


def write_distribution(folder: Path, name: str, entry_points: dict[str, dict[str, str]]) -> None:
    """An installed distribution as importlib.metadata sees it: ``<name>-0.1.dist-info`` on sys.path."""
    info = folder / f"{name}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    lines = []
    for group, entries in entry_points.items():
        lines += [f"[{group}]", *(f"{k} = {v}" for k, v in entries.items()), ""]
    (info / "entry_points.txt").write_text("\n".join(lines))


def test_installed_entry_points_are_discovered(tmp_path, monkeypatch):
    write_distribution(
        tmp_path,
        "renamed_rpr2",
        {
            ENTRY_POINT_GROUP: {"renamed_rpr2": "tests.test_plugins:Renamed"},
            CONFIG_ENTRY_POINT_GROUP: {"renamed_rpr2": "pipeline.config"},
        },
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    assert entry_point_mechanisms(MECHANISMS.builtins) == {"renamed_rpr2": Renamed}
    assert config_search_paths() == ["pkg://pipeline.config"]
    registry = kinematics.MechanismRegistry(MECHANISMS.builtins)
    assert list(registry) == [*MECHANISMS.builtins, "renamed_rpr2"]


def test_a_broken_installed_plugin_fails_the_first_lookup(tmp_path, monkeypatch):
    write_distribution(tmp_path, "broken", {ENTRY_POINT_GROUP: {"broken": "no_such_package.mech:Broken"}})
    monkeypatch.syspath_prepend(str(tmp_path))
    registry = kinematics.MechanismRegistry(MECHANISMS.builtins)  # built lazily: no error yet
    with pytest.raises(
        PluginError,
        match=r"^entry point 'broken = no_such_package.mech:Broken' \(group "
        r"pm_design.mechanisms, distribution broken 0.1\): cannot load: ",
    ):
        registry["h4"]


@pytest.mark.slow
def test_a_broken_installed_plugin_stops_the_import_with_one_line(tmp_path):
    """A process that uses the registry exits with the one-line error naming the entry point."""
    write_distribution(tmp_path, "broken", {ENTRY_POINT_GROUP: {"broken": "no_such_package.mech:Broken"}})
    env = {"PYTHONPATH": f"{tmp_path}:{ROOT}", "PATH": "/usr/bin:/bin"}
    proc = subprocess.run(
        [sys.executable, "-c", "import kinematics; print(kinematics.MECHANISMS['h4'])"],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines()[-1] == (
        "kinematics.plugins.PluginError: entry point 'broken = no_such_package.mech:Broken' (group "
        "pm_design.mechanisms, distribution broken 0.1): cannot load: ModuleNotFoundError: No module named "
        "'no_such_package'"
    )
